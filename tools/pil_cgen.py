"""The drive of a processor-in-the-loop case as C source: ``ls_drive`` (configuration, tables and state,
exactly as the host's closed loop starts it) written as a static initializer that both the host and
the Cortex-M4F build of the replay compile (tools/pil.py, csrc/pil/).

Every field is walked through the binding's type information (cffi, whose declarations are generated
from the headers), so a field added to the drive is written without an edit here. Floats are written
as C99 hexadecimal literals (exact); the tables the drive points to (``ls_lut`` and their values, the
calibration's output table) become static objects of the header, named per case.
"""

from __future__ import annotations

import math

_INT_SUFFIX = {"uint32_t": "u", "uint8_t": "u", "uint16_t": "u", "uint64_t": "ull", "int64_t": "ll"}


def _float(v: float) -> str:
    if math.isnan(v):
        return "NAN"
    if math.isinf(v):
        return "INFINITY" if v > 0 else "-INFINITY"
    return float(v).hex() + "f"


def _int(v: int, cname: str) -> str:
    if cname in ("int32_t", "int") and v == -(2**31):
        return "(-2147483647 - 1)"
    if cname == "int64_t" and v == -(2**63):
        return "(-9223372036854775807ll - 1)"
    return f"{int(v)}{_INT_SUFFIX.get(cname, '')}"


class _Table:
    """A float table of the case: its C name, its initializer (``[n] = {...}``), whether the drive
    writes it (then not const) and its length. (A plain class: the tests load this file without
    registering it as a module, which a dataclass needs.)"""

    __slots__ = ("name", "init", "writable", "n")

    def __init__(self, name: str, init: str, writable: bool, n: int):
        self.name, self.init, self.writable, self.n = name, init, writable, n


class DriveWriter:
    """Writes one case's drive and the objects it points to.

    Parameters
    ----------
    ffi : cffi.FFI
        The binding's ffi (linsense._ctrl).
    prefix : str
        The C names' prefix of this case.
    """

    def __init__(self, ffi, prefix: str):
        self.ffi = ffi
        self.prefix = prefix
        self.objects: dict[int, str] = {}  # address -> C name
        self.defs: list[str] = []
        #: the float tables by address (one object per address: LS_MODE_COMMISSION's demodulator reads
        #: through a table the drive writes, const nowhere then)
        self.tabs: dict[int, _Table] = {}

    def _floats(self, ptr, n: int, writable: bool) -> str:
        addr = int(self.ffi.cast("uintptr_t", ptr))
        if addr not in self.objects:
            name = f"{self.prefix}_tab{len(self.objects)}"
            self.objects[addr] = name
            vals = ", ".join(_float(ptr[k]) for k in range(n))
            self.tabs[addr] = _Table(name, f"[{n}] = {{{vals}}}", writable, n)
        self.tabs[addr].writable |= writable
        return self.objects[addr]

    def _lut(self, ptr) -> str:
        addr = int(self.ffi.cast("uintptr_t", ptr))
        if addr not in self.objects:
            lut = ptr[0]
            tab = self._floats(lut.table, int(lut.len), writable=False)
            name = f"{self.prefix}_lut{len(self.objects)}"
            self.objects[addr] = name
            self.defs.append(f"static const ls_lut {name} = {{{tab}, {int(lut.len)}u, "
                             f"{_float(float(lut.points_per_rad))}}};")
        return "&" + self.objects[addr]

    def value(self, ctype, v, path: str, parent=None) -> str:
        """C initializer of ``v`` (a field's value, cffi) of type ``ctype``."""
        kind = ctype.kind
        if kind == "struct":
            return "{" + ", ".join(f".{n} = {self.value(f.type, getattr(v, n), f'{path}.{n}', v)}"
                                   for n, f in ctype.fields) + "}"
        if kind == "array":
            return "{" + ", ".join(self.value(ctype.item, v[k], f"{path}[{k}]", v)
                                   for k in range(ctype.length)) + "}"
        if kind == "pointer":
            if v == self.ffi.NULL:
                return "NULL"
            item = ctype.item.cname
            if item == "ls_lut":
                return "(ls_lut *)" + self._lut(v)
            if item == "float" and path.endswith("cal.table"):
                return self._floats(v, int(parent.points), writable=True)
            if item == "float" and path.endswith("cal.learn"):  # (LS_MODE_COMMISSION's estimates, 4 points)
                return self._floats(v, 4 * int(parent.points), writable=True)
            raise ValueError(f"{path}: a pointer to {item} the writer does not know")
        if kind == "enum":
            return str(int(v))
        if kind == "primitive":
            if ctype.cname in ("float", "double"):
                return _float(float(v))
            if ctype.cname == "_Bool":
                return "true" if v else "false"
            return _int(int(v), ctype.cname)
        raise ValueError(f"{path}: a field of kind {kind} the writer does not know")

    def writable(self) -> list[tuple[int, int]]:
        """(address, floats) of each table the drive writes (after :meth:`drive`): what a run changes."""
        return [(addr, t.n) for addr, t in self.tabs.items() if t.writable]

    def drive(self, state) -> str:
        """The definitions of the case: its tables, then ``static const ls_drive <prefix>_drive``."""
        body = self.value(self.ffi.typeof("ls_drive"), state[0], "drive")
        tabs = [f"static {'' if t.writable else 'const '}float {t.name}{t.init};" for t in self.tabs.values()]
        return "\n".join(tabs + self.defs + [f"static const ls_drive {self.prefix}_drive = {body};"])
