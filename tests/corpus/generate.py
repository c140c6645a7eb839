#!/usr/bin/env python3
"""Generates the bad-input corpus from the shipped inputs.

Reads the shipped scenes (studies/scenes), campaigns (studies/campaigns), calibrations
(studies/calibrations), the Gmsh mesh (studies/meshes) and an HDF5 phase image that `softhom rve` itself
writes (`[output] microstructure_only = true`), and writes one directory per case:

    WORK/cases/<name>/input.<ext>    the mutated input (plus any mutated side file: mesh, CSV, image)
    WORK/cases/<name>/case.json      subcommand, extra arguments, class, expectation

Each mutation knows its expectation from the path it mutated, never from a hard-coded key list:
  exit 2 and one of `fields` in stderr (the TOML path of the field, or its last component), or
  exit 1 (a valid load that cannot be reached: Gent locking, cut-backs exhausted), with the converged
  rows kept (`expect_files`).
Mutated values keep to the type the shipped file declares (a string key gets a number, a number key a
string, NaN, ...), so that the expectation holds whatever the key-declaration code looks like.

Before mutating, each base is made cheap by shrinking sizes that the file already has (grid, cells,
steps, starts); a `control` case runs every shrunk base unmutated, so a base the shrinking broke shows up
as a failing control case instead of as hundreds of wrong expectations.
"""
import argparse
import copy
import json
import math
import os
import random
import re
import shutil
import struct
import subprocess
import sys
import tomllib
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import tomlwrite  # noqa: E402

# --- what key names mean (by name, so that renamed keys keep working) ---------------------------------
# Integer-valued keys: fractional values and out-of-range integers are errors.
INT_NAMES = {"steps", "seed", "fiber_count", "grid", "cells", "starts", "resolution", "matrix_id", "fiber_id"}
INT_PATTERNS = [re.compile(p) for p in (r"^max_", r"_iterations$", r"_cutbacks$", r"_cells$", r"^cells_")]
# Keys whose value must be > 0: zero and negative values are errors.
POSITIVE_NAMES = {"tolerance", "steps", "grid", "cells", "G", "Jm", "K", "E", "radius", "width", "height",
                  "duration", "dt", "thickness", "inner_radius", "outer_radius", "length", "size", "tau",
                  "starts", "fiber_count", "mesh_size", "interface_size", "cell_size", "voxel_size",
                  "radial_cells", "patch_cells", "resolution"}
# Free text: any string is valid.
FREE_TEXT = {"description", "name"}
# Keys whose string value is a name defined elsewhere in the same file or a file name; a wrong value is
# still an error, so these are mutated like enums.
SEEDS = {"seed"}
# Load-path magnitudes: 1e300 is a valid number but an unreachable load (exit 1) or refused (exit 2).
LOAD_MAGNITUDES = {"stretch", "path"}

# Seconds a valid but unreachable load may take to stop cleanly (cut-backs), against the runner's default.
UNREACHABLE_TIMEOUT = 20

SUBCOMMAND_OF_PREFIX = {"point_": "point", "rve_": "rve", "macro_": "macro"}
# Tables without which a subcommand cannot run (removing one is an error naming it).
REQUIRED_TABLES = {
    "point": ["material", "load"],
    "rve": ["microstructure", "load"],
    "macro": ["geometry", "material", "load"],
    "calibrate": ["model", "curves"],
    "sweep": [],
}
# Keys without a default (where the file has them): removing one is an error naming it. Paths as in
# the TOML, array elements by index; a path the file does not have is left out.
REQUIRED_KEYS = {
    "point": ["load.type", "load.stretch", "material.fiber_invariant"],
    "rve": ["phases.matrix", "phases.fiber", "load.type"],
    "macro": ["geometry.type", "geometry.file", "load.path", "boundary.0.surface"],
    "calibrate": ["curves.0.file", "curves.0.load"],
    "sweep": ["cases.0.load"],
}
# What an empty scene must name: one of the tables that subcommand needs.
EMPTY_FIELDS = {
    "point": ["material", "load"],
    "rve": ["microstructure", "phases", "load"],
    "macro": ["geometry", "material", "load"],
    "calibrate": ["model", "curves"],
    "sweep": ["sweep", "cases", "base"],
}


def is_int_key(name):
    return name in INT_NAMES or any(p.search(name) for p in INT_PATTERNS)


def is_positive_key(name):
    return name in POSITIVE_NAMES or (is_int_key(name) and name.endswith("_cells"))


# --- paths inside a document ----------------------------------------------------------------------------
def path_str(path):
    out = ""
    for p in path:
        if isinstance(p, int):
            out += "[%d]" % p
        else:
            out += ("." if out else "") + p
    return out


def last_name(path):
    for p in reversed(path):
        if isinstance(p, str):
            return p
    return ""


def expected_fields(path):
    """The strings one of which the error must show: the TOML path, the path without array indices,
    its last key (and, for a {value, min, max} parameter, the parameter's name)."""
    fields = [path_str(path), path_str([p for p in path if isinstance(p, str)]), last_name(path)]
    names = [p for p in path if isinstance(p, str)]
    if names and names[-1] in ("value", "min", "max") and len(names) > 1:
        fields.append(names[-2])
    return sorted(set(f for f in fields if f))


def get_at(doc, path):
    for p in path:
        doc = doc[p]
    return doc


def set_at(doc, path, v):
    get_at(doc, path[:-1])[path[-1]] = v


def del_at(doc, path):
    del get_at(doc, path[:-1])[path[-1]]


def walk(node, path=()):
    """Yields (path, value) for every value: tables, arrays and scalars, arrays of scalars included
    element by element."""
    if isinstance(node, dict):
        for k, v in node.items():
            yield path + (k,), v
            yield from walk(v, path + (k,))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            if isinstance(v, (dict, list)) or True:
                yield path + (i,), v
            if isinstance(v, (dict, list)):
                yield from walk(v, path + (i,))


def resolve_files(node, base_dir):
    """Relative file names in a scene are relative to the scene: rewrite those that exist as absolute
    paths, so the case can live in its own directory."""
    if isinstance(node, dict):
        for k, v in node.items():
            if isinstance(v, str) and v and (base_dir / v).is_file() and k not in FREE_TEXT:
                node[k] = str((base_dir / v).resolve())
            else:
                resolve_files(v, base_dir)
    elif isinstance(node, list):
        for i, v in enumerate(node):
            if isinstance(v, str) and v and (base_dir / v).is_file():
                node[i] = str((base_dir / v).resolve())
            else:
                resolve_files(v, base_dir)


# --- the corpus -----------------------------------------------------------------------------------------
class Corpus:
    def __init__(self, work, softhom):
        self.dir = work / "cases"
        self.softhom = softhom
        self.names = set()
        self.seen = set()  # (subcommand, path without indices, mutation): one case each
        self.count = 0

    def add(self, name, klass, sub, text, expect, fields=(), extra=(), files=None, expect_files=(), ext="toml",
            note="", timeout=None):
        name = re.sub(r"[^A-Za-z0-9_.+-]", "_", name)[:120]
        base, i = name, 1
        while name in self.names:
            i += 1
            name = "%s~%d" % (base, i)
        self.names.add(name)
        d = self.dir / name
        d.mkdir(parents=True, exist_ok=True)
        data = text.encode() if isinstance(text, str) else text
        (d / ("input." + ext)).write_bytes(data)
        for fname, content in (files or {}).items():
            (d / fname).write_bytes(content.encode() if isinstance(content, str) else content)
        meta = {"name": name, "class": klass, "subcommand": sub, "input": "input." + ext, "extra": list(extra),
                "expect_exit": list(expect), "fields": list(fields), "expect_files": list(expect_files),
                "note": note, "timeout": timeout}
        (d / "case.json").write_text(json.dumps(meta, indent=1))
        self.count += 1
        return d

    def once(self, sub, path, mutation):
        # One case per subcommand, key name and mutation: "G" is parsed by the same code wherever it is.
        k = (sub, last_name(path) if path else "", mutation)
        if k in self.seen:
            return False
        self.seen.add(k)
        return True


def result_files(sub):
    return {"point": ["response.csv"], "rve": ["response.csv"], "macro": ["response.csv"],
            "sweep": ["cases.csv"], "calibrate": []}[sub]


def extra_args(sub, dry_run=True):
    return ["--dry-run"] if sub == "sweep" and dry_run else (["--jobs", "1"] if sub == "sweep" else [])


# --- shrinking the shipped bases -----------------------------------------------------------------------
def shrink(doc, sub):
    """Smaller sizes for keys the file already has: the corpus tests validation and clean stops, not
    the physics, and every accepted bad input must still finish within the runner's timeout."""
    def visit(node, path):
        if isinstance(node, dict):
            for k, v in list(node.items()):
                if k == "grid" and isinstance(v, list) and all(isinstance(x, int) for x in v):
                    node[k] = [8] * len(v)
                elif k == "cells" and isinstance(v, list) and all(isinstance(x, int) for x in v):
                    node[k] = [min(x, 2) for x in v]
                elif k.endswith("_cells") and isinstance(v, int) and not isinstance(v, bool):
                    # A closed ring needs a few cells around: fewer make the named surfaces vanish.
                    node[k] = min(v, 8 if k.startswith("circumferential") or k.startswith("patch") else 2)
                elif k == "steps" and isinstance(v, int) and not isinstance(v, bool):
                    node[k] = min(v, 3)
                elif k == "starts" and isinstance(v, int) and not isinstance(v, bool):
                    node[k] = 1
                elif k == "resolution" and isinstance(v, list):
                    node[k] = [8 if isinstance(x, int) else x for x in v][:1]
                else:
                    visit(v, path + [k])
        elif isinstance(node, list):
            for v in node:
                visit(v, path)
    visit(doc, [])
    return doc


def load_base(path, sub):
    doc = tomllib.loads(path.read_text())
    resolve_files(doc, path.parent)
    return shrink(doc, sub)


# --- value mutations --------------------------------------------------------------------------------------
def number_mutations(name, v, in_array):
    """(tag, new value, expected exits) for a number the file declares."""
    out = [("string", "1.5", [2]), ("nan", float("nan"), [2]), ("inf", float("inf"), [2])]
    if in_array:
        out = out[1:2]
    if name in LOAD_MAGNITUDES:
        out.append(("1e300", 1e300, [1, 2]))
    if is_int_key(name):
        out.append(("fractional", 2.5, [2]))
        out.append(("minus1", -1, [2]))
        if name not in SEEDS:
            out.append(("1e12", 10**12, [2]))
    elif is_positive_key(name) and not in_array:
        out.append(("zero", 0.0, [2]))
        out.append(("negative", -1.0, [2]))
    if is_int_key(name) and is_positive_key(name):
        out.append(("zero", 0, [2]))
    return out


# Tables whose keys are names the file chooses (campaign definitions, macro regions): a new key there is a
# new definition, not a typo.
NAMED_COLLECTIONS = {"matrices", "sections", "loads", "regions"}


AXIS_OF_COLLECTION = {"matrices": "matrix", "sections": "section", "loads": "load"}


def referenced_names(doc, axis):
    """The names a campaign's axis takes in its products and explicit cases: the definitions that reach
    a case."""
    names = set()
    for table in ("sweep", "cases"):
        for path, v in walk({table: doc.get(table, [])}):
            if isinstance(v, str) and axis in path:
                names.add(v)
    return names


def unused_definition(doc, path):
    """A campaign definition no case uses: its values are never read into a scene."""
    return len(path) >= 2 and path[0] in AXIS_OF_COLLECTION \
        and path[1] not in referenced_names(doc, AXIS_OF_COLLECTION[path[0]])


def toml_mutations(corpus, sub, label, doc, dry_run=True):
    """Value, type, missing-key and unknown-key mutations of one shipped TOML file."""
    extra = extra_args(sub, dry_run)
    for path, v in list(walk(doc)):
        name = last_name(path)
        if sub == "sweep" and unused_definition(doc, path):
            continue
        in_array = isinstance(path[-1], int)
        parent = get_at(doc, path[:-1])
        muts = []  # (class, tag, new value, expected exits)
        if isinstance(v, bool):
            muts += [("wrong-type", "string", "yes", [2]), ("wrong-type", "number", 1, [2])]
        elif isinstance(v, (int, float)):
            for tag, nv, ex in number_mutations(name, v, in_array):
                klass = {"string": "wrong-type", "bool": "wrong-type", "nan": "non-finite", "inf": "non-finite",
                         "-inf": "non-finite", "1e300": "huge", "1e12": "huge", "fractional": "fractional-int",
                         "minus1": "out-of-range", "zero": "out-of-range", "negative": "out-of-range"}[tag]
                muts.append((klass, tag, nv, ex))
        elif isinstance(v, str):
            # A mixed load's "free" entry of F or P has a number as its other valid type (a prescribed
            # component), so a number there is not a type error.
            mixed_free = v == "free" and in_array and name in ("F", "P")
            if (not in_array or name not in FREE_TEXT) and not mixed_free:
                muts.append(("wrong-type", "number", 42, [2]))
            if name not in FREE_TEXT:
                muts.append(("bad-name", "unknown", "zz-no-such-value", [2]))
        elif isinstance(v, list) and v and not all(isinstance(x, dict) for x in v):
            muts.append(("wrong-type", "table", {"zz": 1}, [2]))
            if name in ("grid", "direction", "stretch", "path", "size", "cells", "F", "mu", "alpha"):
                muts.append(("out-of-range", "empty", [], [2]))
        elif isinstance(v, list) and v:
            muts.append(("wrong-type", "number", 3, [2]))
        elif isinstance(v, dict) and path and not ("value" in v and sub == "calibrate"):
            # (a calibration parameter {value, min, max} may also be a bare number: fixed)
            muts.append(("wrong-type", "number", 3, [2]))
        for klass, tag, nv, ex in muts:
            if ex == [1, 2] and "--dry-run" in extra:
                ex = [0, 2]  # a dry run does not run the load: an unreachable one is not an error there
            if not corpus.once(sub, path, tag):
                continue
            m = copy.deepcopy(doc)
            set_at(m, list(path), nv)
            fields = expected_fields(list(path))
            corpus.add("%s.%s.%s" % (label, path_str(list(path)), tag), klass, sub, tomlwrite.dumps(m), ex,
                       fields, extra, expect_files=result_files(sub) if ex == [1] else ())
        # Unknown keys: a typo next to the real key (so only the unknown-key check can refuse it).
        if isinstance(parent, dict) and isinstance(path[-1], str) and not in_array \
                and not (len(path) == 2 and path[0] in NAMED_COLLECTIONS):
            typo = name[:-1] + name[-1] * 2 if len(name) > 2 else name + "x"
            tpath = list(path[:-1]) + [typo]
            if typo not in parent and corpus.once(sub, tpath, "typo"):
                m = copy.deepcopy(doc)
                set_at(m, tpath, copy.deepcopy(v))
                corpus.add("%s.%s.typo" % (label, path_str(tpath)), "unknown-key", sub, tomlwrite.dumps(m), [2],
                           expected_fields(tpath), extra)
    for table in REQUIRED_TABLES[sub]:
        if table in doc and corpus.once(sub, [table], "missing"):
            m = copy.deepcopy(doc)
            del m[table]
            corpus.add("%s.%s.missing" % (label, table), "missing-key", sub, tomlwrite.dumps(m), [2], [table], extra)
    for dotted in REQUIRED_KEYS[sub]:
        path = [int(p) if p.isdigit() else p for p in dotted.split(".")]
        try:
            get_at(doc, path)
        except (KeyError, IndexError, TypeError):
            continue
        if corpus.once(sub, path, "missing"):
            m = copy.deepcopy(doc)
            del_at(m, path)
            corpus.add("%s.%s.missing" % (label, path_str(path)), "missing-key", sub, tomlwrite.dumps(m), [2],
                       expected_fields(path), extra)


def malformed_mutations(corpus, sub, label, text, dry_run=True):
    """Files that are not TOML: the error names the file or the line."""
    extra = extra_args(sub, dry_run)
    fields = ["input.toml", "line"]
    half = text[: len(text) // 2]
    lines = text.splitlines(keepends=True)
    first_key = next((i for i, line in enumerate(lines) if re.match(r"^[A-Za-z_]+\s*=", line)), None)
    duplicated = text + '\ndescription = "x"\ndescription = "y"\n' if first_key is None else \
        "".join(lines[:first_key + 1] + [lines[first_key]] + lines[first_key + 1:])
    cases = {
        "unclosed-string": text + '\nbroken = "abc\n',
        "unclosed-array": half + "\nzz_cut = [1, 2,\n",
        "no-value": text + "\nzz_novalue =\n",
        "duplicate-key": duplicated,
        "duplicate-table": text + "\n[" + (re.findall(r"^\[([A-Za-z_.]+)\]\s*$", text, re.M) or ["zz"])[0]
        + "]\n[" + (re.findall(r"^\[([A-Za-z_.]+)\]\s*$", text, re.M) or ["zz"])[0] + "]\n",
        "bad-escape": text + '\nzz_escape = "\\q"\n',
    }
    for tag, t in cases.items():
        corpus.add("%s.malformed.%s" % (label, tag), "malformed-toml", sub, t, [2], fields, extra)
    rng = random.Random(label)
    corpus.add("%s.binary" % label, "empty-binary", sub, bytes(rng.randrange(256) for _ in range(512)), [2],
               fields, extra)
    corpus.add("%s.nul-bytes" % label, "empty-binary", sub, b"\0" * 64, [2], fields, extra)
    corpus.add("%s.empty" % label, "empty-binary", sub, b"", [2], EMPTY_FIELDS[sub], extra)


# --- absurd sizes and unreachable loads --------------------------------------------------------------------
def find_key(doc, name):
    for path, v in walk(doc):
        if isinstance(path[-1], str) and path[-1] == name:
            return list(path), v
    return None, None


def absurd_and_unreachable(corpus, sub, label, doc):
    def case(tag, klass, m, expect, fields, extra=()):
        # A clean stop may take many cut-backs: more time than a refused input, still bounded.
        corpus.add("%s.%s" % (label, tag), klass, sub, tomlwrite.dumps(m), expect, fields,
                   list(extra) or extra_args(sub), expect_files=result_files(sub) if expect == [1] else (),
                   timeout=UNREACHABLE_TIMEOUT if expect == [1] else None)

    gpath, grid = find_key(doc, "grid")
    if sub == "rve" and gpath and corpus.once(sub, gpath, "absurd3d"):
        m = copy.deepcopy(doc)
        set_at(m, gpath, [100000, 100000, 100000])
        case("grid-1e5-3d", "absurd-size", m, [2], expected_fields(gpath))
        m = copy.deepcopy(doc)
        set_at(m, gpath, [100000, 100000])
        case("grid-1e5-2d", "absurd-size", m, [2], expected_fields(gpath))
    spath, steps = find_key(doc, "steps")
    if spath and sub in ("point", "rve", "macro") and corpus.once(sub, spath, "1e7"):
        m = copy.deepcopy(doc)
        set_at(m, spath, 10**7)
        case("steps-1e7", "absurd-size", m, [2], expected_fields(spath))
    if sub == "rve" and "microstructure" in doc and "arrangement" in doc["microstructure"] \
            and corpus.once(sub, ["microstructure", "fiber_count"], "1e6"):
        m = copy.deepcopy(doc)
        m["microstructure"]["arrangement"] = "random"
        m["microstructure"]["fiber_count"] = 10**6
        case("fiber_count-1e6", "absurd-size", m, [2], ["microstructure.fiber_count", "fiber_count"])
    if sub == "rve" and "microstructure" in doc and "arrangement" in doc["microstructure"] \
            and corpus.once(sub, ["microstructure", "seed"], "minus1"):
        m = copy.deepcopy(doc)
        m["microstructure"].update(arrangement="random", fiber_count=4, seed=-1)
        corpus.add("%s.random-seed-minus1" % label, "out-of-range", sub, tomlwrite.dumps(m), [2],
                   ["microstructure.seed", "seed"], extra_args(sub))
    cpath, cells = find_key(doc, "cells")
    if sub == "macro" and cpath and corpus.once(sub, cpath, "absurd"):
        m = copy.deepcopy(doc)
        set_at(m, cpath, [1000, 1000, 10])
        case("cells-1000x1000x10", "absurd-size", m, [2], expected_fields(cpath))
    # Valid loads that cannot be reached: the run stops cleanly with exit 1 and the converged rows.
    if sub in ("point", "rve") and isinstance(doc.get("load", {}).get("stretch"), (int, float)) \
            and doc["load"].get("type") == "uniaxial" and corpus.once(sub, ["load", "stretch"], "locking"):
        m = copy.deepcopy(doc)
        m["load"]["stretch"] = 40.0
        case("gent-locking", "unreachable", m, [1], [])
    if sub == "rve" and "solver" in doc and corpus.once(sub, ["solver"], "cutbacks"):
        m = copy.deepcopy(doc)
        m["solver"]["max_cutbacks"] = 0
        # Two Newton iterations cannot close a finite step of these nonlinear cells (a tolerance
        # alone is not enough: the residual's round-off floor counts as convergence).
        m["solver"]["max_newton_iterations"] = 2
        m["solver"]["tolerance"] = 1e-300
        case("cutbacks-exhausted", "unreachable", m, [1], [])
    if sub == "macro" and doc.get("load", {}).get("control") == "stretch" and corpus.once(sub, ["load"], "lock"):
        m = copy.deepcopy(doc)
        m["load"]["path"] = [[0.0, 1.0], [1.0, 40.0]]
        case("gent-locking", "unreachable", m, [1], [])


# --- work estimated before it starts, keys that contradict each other --------------------------------------
def estimate_and_contradiction_cases(corpus, src):
    """Sizes refused from an estimate before any work (the FE section mesher, a .geo at a fine mesh_size,
    a calibration's worst case, a matrix-only grid) and keys that contradict each other, each refused
    naming the key; they ran (or ended in std::bad_alloc) before."""
    scenes = src / "studies/scenes"
    rve = load_base(scenes / "rve_ecoflex_circ45.toml", "rve")
    m = copy.deepcopy(rve)
    m["microstructure"] = {"volume_fraction": 0.0, "grid": [65536, 65536]}
    corpus.add("estimate.rve-matrix-only-65536", "absurd-size", "rve", tomlwrite.dumps(m), [2], ["microstructure.grid"])
    for tag, extra, field in [("circle-width", {"width": 0.1}, "width"),
                              ("square-radius", {"shape": "square", "width": 0.07, "radius": 0.1}, "radius"),
                              ("square-arrangement-min_gap", {"min_gap": 0.01}, "min_gap")]:
        m = copy.deepcopy(rve)
        m["microstructure"].update(extra)
        corpus.add("contradiction.rve-%s" % tag, "contradiction", "rve", tomlwrite.dumps(m), [2],
                   ["microstructure." + field])
    fe = load_base(scenes / "rve_ecoflex_circ45_fe.toml", "rve")
    fe["solver"].update(interface_size=0.0005, grading=1e-9)
    corpus.add("estimate.rve-fe-interface_size-grading", "absurd-size", "rve", tomlwrite.dumps(fe), [2],
               ["solver.interface_size"])
    point = load_base(scenes / "point_uniaxial_ecoflex.toml", "point")
    m = copy.deepcopy(point)
    m["load"].update(direction=[1.0, 0.0, 0.0], in_plane=[2.0, 0.0, 0.0])
    corpus.add("contradiction.point-in_plane-parallel", "contradiction", "point", tomlwrite.dumps(m), [2], ["load.in_plane"])
    for tag, p11 in [("nan", float("nan")), ("fre", "fre")]:
        m = copy.deepcopy(point)
        m["load"] = {"type": "mixed", "path": [[0.0, 0.0], [1.0, 1.0]], "steps": 3,
                     "F": [[1.2, 0, 0], [0, "free", 0], [0, 0, "free"]], "P": [[p11, 0, 0], [0, 0, 0], [0, 0, 0]]}
        corpus.add("contradiction.point-P-%s-at-prescribed" % tag, "contradiction", "point", tomlwrite.dumps(m), [2],
                   ["load.P[0][0]"])
    m = copy.deepcopy(point)
    m["material"] = {"law": "neo-hookean", "E": 1e308, "nu": 0.49}  # K = E / (3 (1 - 2 nu)) = inf
    corpus.add("message.point-E-1e308", "out-of-range", "point", tomlwrite.dumps(m), [2], ["material.E"])
    m = copy.deepcopy(point)
    m["load"]["duration"] = 5e-324
    corpus.add("message.point-duration-5e-324", "out-of-range", "point", tomlwrite.dumps(m), [2], ["load.duration = 5e-324"])
    tube_scene = load_base(scenes / "macro_tube_helix15_ecoflex.toml", "macro")
    tube_scene["geometry"]["inner_radius"] = 5e-324
    corpus.add("message.macro-inner_radius-5e-324", "out-of-range", "macro", tomlwrite.dumps(tube_scene), [2],
               ["geometry.inner_radius = 5e-324"])
    cal_file = src / "studies/calibrations/example_point.toml"
    cal = load_base(cal_file, "calibrate")
    # Curve values of ±1e308: the residual's norm overflowed and summary.json refused the fit's numbers.
    m = copy.deepcopy(cal)
    lines = Path(m["curves"][0]["file"]).read_text().splitlines()
    head = next(i for i, line in enumerate(lines) if line and not line.startswith("#"))
    y = lines[head].split(",").index(m["curves"][0]["y"])
    rows = [line.split(",") for line in lines[head + 1:] if line]
    for i, r in enumerate(rows):
        r[y] = "1e308" if i % 2 else "-1e308"
    m["curves"][0]["file"] = "huge.csv"
    corpus.add("message.calibrate-curve-1e308", "csv", "calibrate", tomlwrite.dumps(m), [2], ["curves[0].y"],
               files={"huge.csv": "\n".join([lines[head]] + [",".join(r) for r in rows]) + "\n"})
    cal.setdefault("solver", {}).update(starts=1000, max_iterations=100000)
    corpus.add("estimate.calibrate-starts-iterations", "absurd-size", "calibrate", tomlwrite.dumps(cal), [2],
               ["solver.max_iterations"])
    # The quarter tube's .geo reading its size from mesh_size: at 0.01 mm, 7.6e8 nodes.
    tube = load_base(scenes / "macro_gmsh_tube.toml", "macro")
    geo = (src / "studies/meshes/tube_quarter_tet10.geo").read_text().replace(
        "h = 1.0;", "h = mesh_size;").replace('SetFactory("OpenCASCADE");', 'SetFactory("OpenCASCADE");\nDefineConstant[ mesh_size = 1.0 ];')
    tube["geometry"].pop("file", None)
    tube["geometry"].update(geo="tube.geo", mesh_size=0.01)
    corpus.add("estimate.macro-geo-mesh_size-0.01", "absurd-size", "macro", tomlwrite.dumps(tube), [2],
               ["geometry.mesh_size"], files={"tube.geo": geo})


# --- side files: meshes, CSV curves, HDF5 images -------------------------------------------------------------
def mesh_mutations(corpus, scene_doc, mesh_path):
    """Corrupted copies of a Gmsh mesh behind a shrunk macro scene."""
    text = mesh_path.read_text()
    lines = text.splitlines(keepends=True)
    data = text.encode()
    i_nodes = next(i for i, l in enumerate(lines) if l.startswith("$Nodes"))
    i_elems = next(i for i, l in enumerate(lines) if l.startswith("$Elements"))
    muts = {
        "truncated-10pct": data[: len(data) // 10],
        "truncated-50pct": data[: len(data) // 2],
        "truncated-95pct": data[: len(data) * 95 // 100],
        "truncated-before-elements": "".join(lines[:i_elems]).encode(),
        "empty": b"",
        "garbage": bytes(random.Random(7).randrange(256) for _ in range(4096)),
        "no-format": "".join(lines[3:]).encode(),
        "version-99": text.replace("4.1 0 8", "99 0 8", 1).encode(),
    }
    # Node count in the $Nodes header 1e12 (numEntityBlocks numNodes minTag maxTag).
    hdr = lines[i_nodes + 1].split()
    if len(hdr) == 4:
        l2 = list(lines)
        l2[i_nodes + 1] = "%s %d %s %d\n" % (hdr[0], 10**12, hdr[2], 10**12)
        muts["nodes-1e12"] = "".join(l2).encode()
    # A coordinate "nan" and an element referring to a node that does not exist.
    l3 = list(lines)
    for j in range(i_nodes + 2, i_elems):
        parts = l3[j].split()
        if len(parts) == 3 and all(re.match(r"^-?[0-9.e+-]+$", p) for p in parts) and "." in l3[j]:
            l3[j] = "nan %s %s\n" % (parts[1], parts[2])
            break
    muts["coordinate-nan"] = "".join(l3).encode()
    l4 = list(lines)
    j = i_elems + 3
    while j < len(l4) and len(l4[j].split()) < 5:
        j += 1
    parts = l4[j].split()
    parts[1] = "999999999"
    l4[j] = " ".join(parts) + "\n"
    muts["element-missing-node"] = "".join(l4).encode()
    gpath = ["geometry", "file"]
    for tag, content in muts.items():
        m = copy.deepcopy(scene_doc)
        case_dir = corpus.dir / ("mesh.%s" % tag)
        m["geometry"]["file"] = str(case_dir / "mesh.msh")
        corpus.add("mesh.%s" % tag, "mesh", "macro", tomlwrite.dumps(m), [2], ["mesh.msh", "geometry.file"],
                   files={"mesh.msh": content})
    m = copy.deepcopy(scene_doc)
    m["geometry"]["file"] = "/nonexistent/zz-mesh.msh"
    corpus.add("mesh.missing-file", "mesh", "macro", tomlwrite.dumps(m), [2], ["zz-mesh.msh", "geometry.file"])


def csv_mutations(corpus, cal_doc, label):
    """Bad curve files behind a shrunk calibration."""
    index = next(i for i, c in enumerate(cal_doc["curves"]) if str(c.get("file", "")).endswith(".csv"))
    curve = cal_doc["curves"][index]
    src = Path(curve["file"])
    text = src.read_text()
    lines = text.splitlines()
    header = lines[0]
    cols = header.split(",")
    body = lines[1:]
    mid = len(body) // 2

    def with_row(i, row):
        b = list(body)
        b[i] = row
        return "\n".join([header] + b) + "\n"
    ncol = len(cols)
    muts = {
        "empty": "",
        "header-only": header + "\n",
        "one-row": "\n".join([header, body[0]]) + "\n",
        "text-cell": with_row(mid, ",".join(["abc"] * ncol)),
        "nan-cell": with_row(mid, ",".join(["nan"] * ncol)),
        "inf-cell": with_row(mid, ",".join(["inf"] * ncol)),
        "ragged-row": with_row(mid, body[mid].split(",")[0]),
        "extra-cells": with_row(mid, body[mid] + ",1,2,3"),
        "wrong-header": "\n".join([",".join("zz%d" % i for i in range(ncol))] + body) + "\n",
        "binary": bytes(random.Random(3).randrange(256) for _ in range(1024)),
    }
    name = curve.get("name", "")
    for tag, content in muts.items():
        m = copy.deepcopy(cal_doc)
        case_dir = corpus.dir / ("%s.csv.%s" % (label, tag))
        m["curves"][index]["file"] = str(case_dir / "curve.csv")
        fields = ["curve.csv", "curves[%d]" % index] + ([name] if name else [])
        corpus.add("%s.csv.%s" % (label, tag), "csv", "calibrate", tomlwrite.dumps(m), [2], fields,
                   files={"curve.csv": content})
    m = copy.deepcopy(cal_doc)
    m["curves"][index]["file"] = "/nonexistent/zz-curve.csv"
    corpus.add("%s.csv.missing-file" % label, "csv", "calibrate", tomlwrite.dumps(m), [2],
               ["zz-curve.csv", "curves[%d].file" % index])


def find_run(data, allowed, min_len, min_ones):
    """Start and end of the one maximal run of bytes in `allowed`, at least `min_len` long with at least
    `min_ones` non-zero bytes: the raw data of a uint8 phase image (HDF5 stores small datasets
    contiguously and unfiltered)."""
    runs, start = [], None
    for i, b in enumerate(data + b"\xff"):
        if b in allowed and i < len(data):
            if start is None:
                start = i
        elif start is not None:
            if i - start >= min_len and sum(1 for x in data[start:i] if x) >= min_ones:
                runs.append((start, i))
            start = None
    return runs


def image_mutations(corpus, softhom, rve_doc, work):
    """A phase image written by softhom itself, then damaged: missing, truncated, garbage, wrong dataset,
    out-of-range phase id, NaN and out-of-range fractions."""
    gen = work / "image-source"
    shutil.rmtree(gen, ignore_errors=True)
    gen.mkdir(parents=True)
    src = copy.deepcopy(rve_doc)
    src["microstructure"]["grid"] = [16, 16]
    src.setdefault("output", {})["microstructure_only"] = True
    (gen / "scene.toml").write_text(tomlwrite.dumps(src))
    r = subprocess.run([str(softhom), "rve", str(gen / "scene.toml"), "--out", str(gen / "out"), "--threads", "1"],
                       capture_output=True, text=True, timeout=60)
    h5 = gen / "out" / "microstructure.h5"
    if r.returncode != 0 or not h5.is_file():
        print("corpus: could not write the phase image (exit %d): %s" % (r.returncode, r.stderr.strip()),
              file=sys.stderr)
        return
    data = h5.read_bytes()
    base = copy.deepcopy(rve_doc)
    micro = {k: v for k, v in base["microstructure"].items() if k in ("fiber_angle_deg",)}

    def scene_with(image):
        m = copy.deepcopy(base)
        m["microstructure"] = dict(micro, image=image)
        return m

    def add(tag, image, content, fields, expect=(2,), klass="image"):
        case_dir = corpus.dir / ("image.%s" % tag)
        image = {k: (str(case_dir / "phase.h5") if v == "@" else v) for k, v in image.items()}
        corpus.add("image.%s" % tag, klass, "rve", tomlwrite.dumps(scene_with(image)), list(expect), fields,
                   files={"phase.h5": content} if content is not None else None)

    ffields = ["phase.h5", "microstructure.image.file", "image.file"]
    dfields = ["microstructure.image.dataset", "dataset"]
    add("control", {"file": "@"}, data, [], expect=(0,), klass="control")
    add("missing-file", {"file": "/nonexistent/zz-phase.h5"}, None, ["zz-phase.h5"] + ffields[1:])
    add("truncated", {"file": "@"}, data[: len(data) // 2], ffields)
    add("truncated-header", {"file": "@"}, data[:100], ffields)
    add("garbage", {"file": "@"}, bytes(random.Random(5).randrange(256) for _ in range(len(data))), ffields)
    add("empty", {"file": "@"}, b"", ffields)
    add("dataset-missing", {"file": "@", "dataset": "/zz_nope"}, data, dfields + ["zz_nope"])
    add("dataset-normals", {"file": "@", "dataset": "/interface_normal"}, data, dfields + ["interface_normal"])
    add("normal-dataset-wrong-dims", {"file": "@", "dataset": "/fiber_fraction", "normal_dataset": "/phase"}, data,
        ["microstructure.image.normal_dataset", "normal_dataset"])
    add("direction-dataset-wrong-dims", {"file": "@", "direction_dataset": "/fiber_fraction"}, data,
        ["microstructure.image.direction_dataset", "direction_dataset"])
    add("voxel_size-nan", {"file": "@", "voxel_size": float("nan")}, data,
        ["microstructure.image.voxel_size", "voxel_size"], klass="non-finite")
    add("voxel_size-zero", {"file": "@", "voxel_size": 0.0}, data,
        ["microstructure.image.voxel_size", "voxel_size"], klass="out-of-range")
    add("cell_size-negative", {"file": "@", "cell_size": -1.0}, data,
        ["microstructure.image.cell_size", "cell_size"], klass="out-of-range")
    add("fiber_id-string", {"file": "@", "fiber_id": "1"}, data, ["microstructure.image.fiber_id", "fiber_id"],
        klass="wrong-type")
    add("matrix_id-fractional", {"file": "@", "matrix_id": 0.5}, data, ["microstructure.image.matrix_id", "matrix_id"],
        klass="fractional-int")
    # Patch the raw data: a phase id 7 in the uint8 image, NaN / 1.5 / -0.5 in the fraction image.
    n = 16 * 16
    runs = find_run(data, {0, 1}, n, 8)
    if len(runs) == 1:
        s, e = runs[0]
        first_one = s + data[s:e].index(1)
        patched = bytearray(data)
        patched[first_one] = 7
        add("phase-id-7", {"file": "@"}, bytes(patched), dfields + ["phase", "7"])
    else:
        print("corpus: phase image data not found unambiguously (%d runs); id case left out" % len(runs),
              file=sys.stderr)
    one, zero = struct.pack("<d", 1.0), struct.pack("<d", 0.0)
    hits = [i for i in range(0, len(data) - 24) if data[i:i + 8] == one and data[i + 8:i + 16] == one
            and data[i + 16:i + 24] in (one, zero)]
    if hits:
        for tag, val in (("fraction-nan", float("nan")), ("fraction-1.5", 1.5), ("fraction-negative", -0.5)):
            patched = bytearray(data)
            patched[hits[0]:hits[0] + 8] = struct.pack("<d", val)
            add(tag, {"file": "@", "dataset": "/fiber_fraction"}, bytes(patched), dfields + ["fiber_fraction"])


# --- campaigns ------------------------------------------------------------------------------------------------
def campaign_specials(corpus, doc, label):
    if "sweep" in doc:
        m = copy.deepcopy(doc)
        sweeps = m["sweep"] if isinstance(m["sweep"], list) else [m["sweep"]]
        sweeps[0]["angle"] = [i * 0.09 for i in range(1000)]
        sweeps[0]["volume_fraction"] = [i * 0.0005 for i in range(1000)]
        corpus.add("%s.product-1e6" % label, "absurd-size", "sweep", tomlwrite.dumps(m), [2],
                   ["sweep", "cases", "angle", "volume_fraction"], ["--dry-run"])
    # A real (not dry) run of one case that locks: the sweep ends with exit 1, rows kept in cases.csv.
    m = copy.deepcopy(doc)
    for path, v in list(walk(m)):
        if isinstance(path[-1], str) and path[-1] == "stretch" and isinstance(v, (int, float)) and v > 1:
            set_at(m, list(path), 40.0)
    if "sweep" in m:
        m.pop("cases", None)
        for sw in (m["sweep"] if isinstance(m["sweep"], list) else [m["sweep"]])[:1]:
            for k, v in sw.items():
                if isinstance(v, list) and v:
                    sw[k] = v[:1]
        if isinstance(m["sweep"], list):
            m["sweep"] = m["sweep"][:1]
    corpus.add("%s.run-locking" % label, "unreachable", "sweep", tomlwrite.dumps(m), [1], [], ["--jobs", "1"],
               expect_files=["cases.csv"], timeout=UNREACHABLE_TIMEOUT)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--source-dir", type=Path, required=True)
    ap.add_argument("--work", type=Path, required=True)
    ap.add_argument("--softhom", type=Path, required=True)
    a = ap.parse_args()
    src = a.source_dir.resolve()
    shutil.rmtree(a.work / "cases", ignore_errors=True)
    corpus = Corpus(a.work.resolve(), a.softhom)

    scenes = sorted((src / "studies/scenes").glob("*.toml"))
    for f in scenes:
        sub = next((s for p, s in SUBCOMMAND_OF_PREFIX.items() if f.name.startswith(p)), None)
        if sub is None:
            continue
        doc = load_base(f, sub)
        if doc.get("solver", {}).get("engine") == "fe":
            continue  # the FE RVE engine meshes with CGAL: too slow for a per-case timeout of seconds
        label = f.stem
        corpus.add("%s.control" % label, "control", sub, tomlwrite.dumps(doc),
                   [1] if "locking" in f.stem else [0], [], extra_args(sub))
        toml_mutations(corpus, sub, label, doc)
        absurd_and_unreachable(corpus, sub, label, doc)
        if corpus.once(sub, [], "malformed"):
            malformed_mutations(corpus, sub, label, f.read_text())
        if doc.get("geometry", {}).get("type") == "gmsh":
            mesh_mutations(corpus, doc, Path(doc["geometry"]["file"]))
    for f in sorted((src / "studies/calibrations").glob("*.toml")):
        doc = load_base(f, "calibrate")
        if any("campaign" in c for c in doc.get("curves", [])):
            continue  # its curves are read from a campaign store that only a full sweep writes
        corpus.add("%s.control" % f.stem, "control", "calibrate", tomlwrite.dumps(doc), [0], [])
        toml_mutations(corpus, "calibrate", f.stem, doc)
        if corpus.once("calibrate", [], "malformed"):
            malformed_mutations(corpus, "calibrate", f.stem, f.read_text())
        if doc.get("curves") and any(str(c.get("file", "")).endswith(".csv") for c in doc["curves"]) \
                and corpus.once("calibrate", [], "csv"):
            csv_mutations(corpus, doc, f.stem)
    # The small demo campaign first: the campaign-wide cases (1e6 product, a real run) take it as base.
    for f in sorted((src / "studies/campaigns").glob("*.toml"), key=lambda f: (f.stem != "demo_ecoflex", f.stem)):
        doc = load_base(f, "sweep")
        corpus.add("%s.control" % f.stem, "control", "sweep", tomlwrite.dumps(doc), [0], [], ["--dry-run"])
        toml_mutations(corpus, "sweep", f.stem, doc)
        if corpus.once("sweep", [], "malformed"):
            malformed_mutations(corpus, "sweep", f.stem, f.read_text())
        if corpus.once("sweep", [], "specials"):
            campaign_specials(corpus, doc, f.stem)
    estimate_and_contradiction_cases(corpus, src)
    rve_base = next((f for f in scenes if f.name == "rve_ecoflex_circ45.toml"), None)
    if rve_base:
        image_mutations(corpus, a.softhom, load_base(rve_base, "rve"), a.work.resolve())
    print("corpus: %d cases in %s" % (corpus.count, corpus.dir))


if __name__ == "__main__":
    main()
