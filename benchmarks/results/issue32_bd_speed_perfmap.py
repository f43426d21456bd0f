"""`perf` profiles of the numba BD kernels, by function and by instruction (issue 32).

``perf`` cannot name JIT code by itself; this module writes ``/tmp/perf-<pid>.map`` for the
compiled kernels (entry addresses from the JIT, symbol sizes from ``nm`` of each library's
object code; numba drops that object code after loading a cached kernel, so import this
module *before* the kernels are first called) and keeps each object file for ``objdump``::

    perf record -F 4000 -o perf.data python benchmarks/results/issue32_bd_speed_perfmap.py suspension 4000
    perf report -i perf.data --no-children --sort sym          # per kernel function
    python benchmarks/results/issue32_bd_speed_perfmap.py annotate perf.data /tmp/bd_obj_run.o _central_forces

Workloads: ``suspension STEPS`` (the stable suspension of bench_brownian.py's rate part, ``bd.run``)
and ``gel STEPS`` (model A at 2 a²/D0, ``bd.run_tangential``; issue32_bd_speed_state.py).  The
machine's VM exposes no hardware counters: samples are timer based.
"""
import collections
import os
import re
import subprocess
import sys
import tempfile

from numba.core import codegen as _cg

_orig_set = _cg.CPUCodeLibrary._set_compiled_object


def _set(self, value):  # keep a copy of each library's object code (numba consumes it)
    self._perfmap_obj = value
    return _orig_set(self, value)


_cg.CPUCodeLibrary._set_compiled_object = _set
_orig_hook = _cg.CPUCodeLibrary._object_compiled_hook.__func__


def _hook(cls, ll_module, buf):  # the same for a kernel compiled in this process
    lib = getattr(ll_module, "_CPUCodeLibrary__library", None)
    if lib is not None:
        lib._perfmap_obj = buf
    return _orig_hook(cls, ll_module, buf)


_cg.CPUCodeLibrary._object_compiled_hook = classmethod(_hook)


def _short(name):
    """``polypack._kernels.bd._project`` from the mangled name."""
    m = re.match(r"_ZN(.*)", name)
    if not m:
        return name
    s = m.group(1)
    parts = []
    while s and s[0].isdigit():
        k = re.match(r"(\d+)", s).group(1)
        parts.append(s[len(k):len(k) + int(k)])
        s = s[len(k) + int(k):]
    return ".".join(p for p in parts if not p.startswith("B"))[:80] or name[:80]


def write_map(dispatchers, objdir="/tmp"):
    """Write the perf map of every compiled overload of ``dispatchers``; returns the number of symbols."""
    ents = {}
    for disp in dispatchers:
        for cres in disp.overloads.values():
            lib = cres.library
            obj = getattr(lib, "_perfmap_obj", None)
            if not obj:
                continue
            path = os.path.join(objdir, f"bd_obj_{disp.py_func.__name__}.o")
            with open(path, "wb") as fh:
                fh.write(obj)
            out = subprocess.run(["nm", "-S", "--defined-only", path], capture_output=True, text=True).stdout
            syms = [(int(f[0], 16), int(f[1], 16), f[3]) for f in (x.split() for x in out.splitlines())
                    if len(f) == 4 and f[2] in "tTW"]
            base = None
            for off, _size, name in syms:
                if name == cres.fndesc.llvm_func_name:
                    base = lib.get_pointer_to_function(name) - off
            if base is None:
                continue
            for off, size, name in syms:
                ents[base + off] = (size, _short(name))
    with open(f"/tmp/perf-{os.getpid()}.map", "w") as fh:
        for a in sorted(ents):
            fh.write(f"{a:x} {ents[a][0]:x} {ents[a][1]}\n")
    return len(ents)


def annotate(data, obj, func, threshold=0.0):
    """Per-instruction share of ``func``'s samples (``perf script`` offsets on ``objdump`` of ``obj``)."""
    out = subprocess.run(["perf", "script", "-i", data, "-F", "ip,sym,symoff"], capture_output=True, text=True).stdout
    cnt = collections.Counter()
    for line in out.splitlines():
        if func in line and "+0x" in line:
            cnt[int(line.rsplit("+0x", 1)[1], 16)] += 1
    nm = subprocess.run(["nm", "-S", obj], capture_output=True, text=True).stdout
    start = size = None
    for f in (x.split() for x in nm.splitlines()):
        if len(f) == 4 and func.split(".")[-1] in f[3] and f[2] in "tTW" and f[3].startswith("_ZN8"):
            start, size = int(f[0], 16), int(f[1], 16)
            break
    asm = subprocess.run(["objdump", "-d", "--no-show-raw-insn", obj, f"--start-address={start}",
                          f"--stop-address={start + size}"], capture_output=True, text=True).stdout
    tot = sum(cnt.values()) or 1
    for line in asm.splitlines():
        m = re.match(r"\s*([0-9a-f]+):\s*(.*)", line)
        if m:
            a = int(m.group(1), 16) - start
            c = 100 * cnt.get(a, 0) / tot
            if c >= threshold:
                print(f"{c:5.1f} {a:5x}: {re.sub(r'<_ZN[^>]*>', '', m.group(2))}")
    print("samples", tot)


def main():
    if sys.argv[1] == "annotate":
        annotate(*sys.argv[2:5], *(float(x) for x in sys.argv[5:6]))
        return
    import time

    here = os.path.dirname(os.path.abspath(__file__))
    sys.path[:0] = [here, os.path.join(here, "..")]
    from polypack._kernels import bd, cells

    steps = int(sys.argv[2])
    if sys.argv[1] == "suspension":
        from bench_brownian import _repulsive_setup
        from polypack.generate import brownian as B

        p, pos, L = _repulsive_setup(4000)
        sim = B.BrownianSimulation(pos, L, p, bond_width=None, cutoff=(2.0 + 30 * p.debye_length / p.radius) * p.radius,
                                   seed=2)
        sim.run(10)
        t0 = time.process_time()
        sim.run(steps)
    else:
        from issue32_bd_speed_state import make_sim

        sim, _ = make_sim(4000, 2.0)
        a = (sim._box, sim._params, sim._state, sim._istate, sim._table, sim._bonds, sim._adj, sim._deg, sim._ncell,
             sim._rng)
        bd.run_tangential(sim._pos.copy(), *[x.copy() for x in a], 3, sim._anchors.copy(), sim._orient.copy())
        t0 = time.process_time()
        bd.run_tangential(sim._pos, *a, steps, sim._anchors, sim._orient)
    t = time.process_time() - t0
    print(f"{sys.argv[1]}: {t / (sim.n * steps) * 1e9:.1f} ns per particle-step, load "
          f"{open('/proc/loadavg').read().split()[0]}")
    ds = [getattr(m, k) for m in (bd, cells) for k in dir(m) if hasattr(getattr(m, k), "overloads")]
    print("perf map symbols:", write_map(ds))


if __name__ == "__main__":
    main()
