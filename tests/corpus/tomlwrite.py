"""A minimal TOML writer for the corpus: enough for the shipped scenes (tables, arrays of tables, inline
tables inside arrays, strings, booleans, integers, floats including nan/inf). Python's stdlib reads
TOML (tomllib) but does not write it."""
import math
import re

_BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")


def key(k):
    return k if _BARE_KEY.match(k) else '"' + _escape(k) + '"'


def _escape(s):
    out = []
    for ch in s:
        if ch == "\\":
            out.append("\\\\")
        elif ch == '"':
            out.append('\\"')
        elif ord(ch) < 0x20 or ord(ch) == 0x7F:
            out.append("\\u%04x" % ord(ch))
        else:
            out.append(ch)
    return "".join(out)


def value(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return '"' + _escape(v) + '"'
    if isinstance(v, list):
        return "[" + ", ".join(value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(key(k) + " = " + value(x) for k, x in v.items()) + "}"
    raise TypeError("cannot write %r as TOML" % (v,))


def _is_table_array(v):
    return isinstance(v, list) and len(v) > 0 and all(isinstance(x, dict) for x in v)


def _write_table(lines, path, table):
    scalars = [(k, v) for k, v in table.items() if not isinstance(v, dict) and not _is_table_array(v)]
    subtables = [(k, v) for k, v in table.items() if isinstance(v, dict)]
    arrays = [(k, v) for k, v in table.items() if _is_table_array(v)]
    for k, v in scalars:
        lines.append(key(k) + " = " + value(v))
    for k, v in subtables:
        sub = path + [key(k)]
        lines.append("")
        lines.append("[" + ".".join(sub) + "]")
        _write_table(lines, sub, v)
    for k, items in arrays:
        sub = path + [key(k)]
        for item in items:
            lines.append("")
            lines.append("[[" + ".".join(sub) + "]]")
            _write_table(lines, sub, item)


def dumps(doc):
    lines = []
    _write_table(lines, [], doc)
    return "\n".join(lines).lstrip("\n") + "\n"
