#!/usr/bin/env python3
"""The one-way layering of softhom's libraries, checked from the sources and the CMake files.

Every top-level library folder sits on a floor (FLOORS below, the table of CONTRIBUTING.md). The check
fails when
  - a file of folder D includes a header of a library on the same or a higher floor than D
    ("softhom/<lib>/..." with lib != D),
  - a library's CMake target links a softhom library on the same or a higher floor,
  - a file includes a softhom library that its folder's target does not link (directly or through the
    libraries it links): the include works only by accident of include paths,
  - the CMake link graph of the softhom libraries has a cycle.

    python3 scripts/check_layers.py [--source-dir DIR]

Exit 0 and one summary line when the house is in order; exit 1 and one line per violation otherwise.
"""
import argparse
import pathlib
import re
import sys

# Floor of each library folder, ground first. Folders on one floor do not include each other.
FLOORS = {
    "core": 0,
    "materials": 1, "fft": 1,
    "fe": 2,
    "io": 3,
    "rve": 4, "macro": 4,
    "studies": 5,
    "jobs": 6,
    "apps": 7, "python": 7,
}
# CMake targets that are not softhom_<folder>, by the folder that defines them.
OTHER_TARGETS = {"softhom": "apps", "softhom_python": "python",
                 "softhom_mpi": "core"}
SOURCE_SUFFIXES = {".hpp", ".cpp", ".h", ".cc"}
INCLUDE = re.compile(r'^\s*#\s*include\s*[<"]softhom/([a-z_]+)/', re.M)
LINK_CALL = re.compile(r"target_link_libraries\s*\(\s*([A-Za-z0-9_]+)([^)]*)\)", re.S)
SOFTHOM_LIB = re.compile(r"\bsofthom(?:::|_)([a-z_]+)\b")


def folder_of(token):
    return OTHER_TARGETS.get(f"softhom_{token}", token)


def cmake_links(root):
    """softhom library folder -> set of softhom library names it links (by folder name)."""
    links = {}
    for folder in FLOORS:
        cmake = root / folder / "CMakeLists.txt"
        if not cmake.exists():
            continue
        text = re.sub(r"#[^\n]*", "", cmake.read_text())
        own = set()
        for _target, args in LINK_CALL.findall(text):
            own |= {folder_of(m) for m in SOFTHOM_LIB.findall(args)}
        links[folder] = {lib for lib in own if lib in FLOORS and lib != folder}
    return links


def closure(links, folder):
    seen, todo = set(), list(links.get(folder, ()))
    while todo:
        lib = todo.pop()
        if lib not in seen:
            seen.add(lib)
            todo.extend(links.get(lib, ()))
    return seen


def find_cycle(links):
    state = {}

    def visit(node, path):
        state[node] = 1
        for nxt in links.get(node, ()):
            if state.get(nxt) == 1:
                return path + [node, nxt]
            if nxt not in state:
                found = visit(nxt, path + [node])
                if found:
                    return found
        state[node] = 2
        return None

    for node in links:
        if node not in state:
            found = visit(node, [])
            if found:
                return found
    return None


def check(root):
    problems = []
    links = cmake_links(root)
    for folder, libs in links.items():
        for lib in sorted(libs):
            if FLOORS[lib] >= FLOORS[folder]:
                problems.append(f"{folder}/CMakeLists.txt: {folder}/ links softhom::{lib}, "
                                f"which is on floor {FLOORS[lib]}, not below {folder}'s floor {FLOORS[folder]}")
    cycle = find_cycle(links)
    if cycle:
        problems.append("CMake link cycle: " + " -> ".join(cycle))
    includes = 0
    for folder in FLOORS:
        base = root / folder
        if not base.is_dir():
            continue
        reachable = closure(links, folder)
        for path in sorted(base.rglob("*")):
            if path.suffix not in SOURCE_SUFFIXES or not path.is_file():
                continue
            rel = path.relative_to(root)
            for lib in sorted(set(INCLUDE.findall(path.read_text(errors="replace")))):
                includes += 1
                if lib == folder or lib not in FLOORS:
                    continue
                if FLOORS[lib] >= FLOORS[folder]:
                    problems.append(f"{rel}: includes softhom/{lib}/ (floor {FLOORS[lib]}) from floor "
                                    f"{FLOORS[folder]}: an include that runs up or sideways")
                elif lib not in reachable:
                    problems.append(f"{rel}: includes softhom/{lib}/ but the targets of {folder}/ do not link "
                                    f"softhom::{lib}")
    return problems, includes, links


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--source-dir", default=pathlib.Path(__file__).resolve().parent.parent, type=pathlib.Path)
    args = parser.parse_args()
    problems, includes, links = check(args.source_dir)
    for line in problems:
        print(line)
    if problems:
        print(f"{len(problems)} layering violation(s)")
        return 1
    print(f"layers in order: {len(links)} libraries, {includes} softhom includes, every one runs down to a linked library")
    return 0


if __name__ == "__main__":
    sys.exit(main())
