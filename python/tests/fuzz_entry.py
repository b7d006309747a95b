"""Seeded mutation fuzz of the Python and PETSc entry points (issue #30).

    python3 python/tests/fuzz_entry.py [--secs S] [--seed N] [--petsc-cases K] [--case C]

The CLI fuzz (``tests/fuzz.rs``) feeds mutated bundled inputs to the ``linpd`` binary. This
script feeds mutated bundled scenes (every static ``data/*.json``, with its node file) to

* the Python package: ``linpd.Scene`` from the mutated file, or (half of the cases) from the
  mutated document as a dict, which can hold NaN and infinity that JSON cannot; then
  ``assemble_rows`` of the first rows, ``solve``, and ``write_result`` of the solution;
* the PETSc driver (``--petsc-cases`` cases, 2 ranks): ``mpiexec -n 2 python -m linpd.petsc``.

Each case runs in a fresh directory as a child process with ``LINPD_MEMORY_GIB=2``, an address
space limit of 8 GiB (``RLIMIT_AS``; the memory cap per run), and a 20 s wall-clock limit.
Classes (the script exits 1 on any of the first five):

* ``python_exception``: the child raised something other than ``linpd.LinpdError`` (a bug: a
  bad input must be a ``LinpdError`` with linpd's message);
* ``signal``: ended by a signal we did not send (a Rust panic across the boundary aborts);
* ``output_from_failed_run``: a failed run left files in its output directory;
* ``success_without_result`` / ``non_finite_result``: exit 0 without a parsable ``result.json``,
  or with NaN/inf in it;
* ``timeout`` (reported, not failed: a valid problem the mutation made large);
* ``ok_rejected`` (a ``LinpdError``, or the driver's non-zero exit with a message), ``ok_success``.

The counts go to docs/robustness.md. Reproduce a case: ``--seed N --case C`` (it keeps the case
directory and prints its path).
"""

import argparse
import json
import math
import os
import random
import resource
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "data"
TIMEOUT = 20.0
AS_LIMIT = 8 << 30

CHILD = r"""
import json, math, sys
import numpy as np
import linpd
mode, path = sys.argv[1], sys.argv[2]
try:
    if mode == "dict":
        with open(path) as f:
            doc = json.load(f)  # NaN and Infinity tokens become floats
        s = linpd.Scene(doc, base_dir=".")
    else:
        s = linpd.Scene(path)
    n = s.row_info()[0]
    s.assemble_rows(0, min(n, 6))
    r = s.solve()
    s.write_result(r["u"].reshape(-1), r["report"], "out")
except linpd.LinpdError as e:
    sys.stderr.write(f"LinpdError: {e}\n")
    sys.exit(3)
"""


def scenes():
    """Static bundled scenes (no pipelines, no dynamics) with their node files."""
    out = []
    for p in sorted(DATA.glob("*.json")):
        if p.name.endswith(".pipeline.json"):
            continue
        doc = json.loads(p.read_text())
        if "dynamics" in doc:
            continue
        side = [doc["nodes"][k] for k in ("csv", "vtk") if isinstance(doc.get("nodes"), dict) and k in doc["nodes"]]
        out.append((p.name, doc, side))
    return out


def pointers(v, at=""):
    yield at
    if isinstance(v, dict):
        for k, x in v.items():
            yield from pointers(x, f"{at}/{k}")
    elif isinstance(v, list):
        for i, x in enumerate(v):
            yield from pointers(x, f"{at}/{i}")


def get(doc, ptr):
    for t in ptr.split("/")[1:]:
        doc = doc[int(t)] if isinstance(doc, list) else doc[t]
    return doc


def parent(doc, ptr):
    toks = ptr.split("/")[1:]
    for t in toks[:-1]:
        doc = doc[int(t)] if isinstance(doc, list) else doc[t]
    last = toks[-1]
    return doc, int(last) if isinstance(doc, list) else last


SPECIAL = [0, -0.0, -1, 1e-308, 5e-324, 1e308, 1e18, 4294967297, 0.5, math.nan, math.inf, -math.inf]


def mutate(rng, doc, strings):
    """One mutation of the parsed document, in place; returns its description."""
    ptrs = [p for p in pointers(doc) if p]
    if not ptrs:
        return "none"
    ptr = rng.choice(ptrs)
    holder, key = parent(doc, ptr)
    old = get(doc, ptr)
    op = rng.randrange(7)
    if op in (0, 1) and isinstance(old, (int, float)) and not isinstance(old, bool):
        new = rng.choice(SPECIAL) if op == 0 else old * rng.choice([10, 0.1, 2, 0.5, -1])
        holder[key] = new
        return f"{ptr}: {old!r} -> {new!r}"
    if op == 2 and isinstance(holder, dict):
        del holder[key]
        return f"{ptr}: deleted"
    if op == 3:
        new = rng.choice(["x", None, [], {}, True, 1.5, rng.choice(strings)])
        holder[key] = new
        return f"{ptr}: -> {new!r}"
    if op == 4 and isinstance(old, list) and old:
        old.append(json.loads(json.dumps(rng.choice(old), allow_nan=True)))
        return f"{ptr}: element duplicated"
    if op == 5 and isinstance(old, dict):
        old["bogus"] = 1
        return f"{ptr}: unknown key added"
    if isinstance(old, str):
        new = rng.choice(strings)
        holder[key] = new
        return f"{ptr}: {old!r} -> {new!r}"
    holder[key] = rng.choice(SPECIAL)
    return f"{ptr}: -> special number"


def strings_of(docs):
    out = set()
    for d in docs:
        for p in pointers(d):
            v = get(d, p) if p else d
            if isinstance(v, str):
                out.add(v)
    return sorted(out)


def limit_memory():
    resource.setrlimit(resource.RLIMIT_AS, (AS_LIMIT, AS_LIMIT))


def finite_result(path):
    try:
        doc = json.loads(path.read_text())
    except (OSError, ValueError):
        return None

    def ok(v):
        if isinstance(v, list):
            return all(ok(x) for x in v)
        return isinstance(v, (int, float)) and math.isfinite(v)

    if "pieces" in doc:
        # the driver's per-rank output: finite balance, every piece present without NaN/inf
        pieces = [path.parent / p for p in doc["pieces"]]
        if not all(p.exists() for p in pieces):
            return None
        text = " ".join(p.read_text().lower() for p in pieces)
        return ok(doc["balance"]["applied"]) and ok(doc["balance"]["reaction"]) and not any(
            w in text.split() for w in ("nan", "inf", "-inf"))
    return ok(doc.get("u")) and ok(doc.get("x"))


def run(cmd, cwd, env):
    t = time.monotonic()
    p = subprocess.Popen(cmd, cwd=cwd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         preexec_fn=limit_memory, start_new_session=True)
    try:
        out, err = p.communicate(timeout=TIMEOUT)
        timed_out = False
    except subprocess.TimeoutExpired:
        os.killpg(p.pid, signal.SIGKILL)
        out, err = p.communicate()
        timed_out = True
    return p.returncode, err.decode(errors="replace"), timed_out, time.monotonic() - t


def classify(code, err, timed_out, case_dir, petsc):
    if timed_out:
        return "timeout"
    out = case_dir / "out"
    if code is not None and code < 0:
        return "signal"
    if code == 0:
        fin = finite_result(out / "result.json")
        if fin is None:
            return "success_without_result"
        return "ok_success" if fin else "non_finite_result"
    if out.exists() and any(out.iterdir()):
        return "output_from_failed_run"
    # a rejection is linpd's: a LinpdError (the API child prints it) or the driver's
    # `error: ...` line; a traceback of anything else is a bug
    if "Traceback" in err or not err.strip():
        return "python_exception"
    if not petsc and "LinpdError: " not in err:
        return "python_exception"
    if petsc and "error" not in err:
        return "python_exception"
    return "ok_rejected"


FAILURES = {"python_exception", "signal", "output_from_failed_run", "success_without_result",
            "non_finite_result"}


def make_case(rng, inputs, strings, work):
    name, doc, side = rng.choice(inputs)
    doc = json.loads(json.dumps(doc))
    muts = [mutate(rng, doc, strings) for _ in range(rng.choice([1, 1, 2, 3]))]
    work.mkdir(parents=True)
    for f in side:
        shutil.copy(DATA / f, work / f)
    (work / "scene.json").write_text(json.dumps(doc, allow_nan=True))
    return name, muts


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--secs", type=float, default=float(os.environ.get("LINPD_PY_FUZZ_SECS", 30)))
    ap.add_argument("--seed", type=int, default=int(os.environ.get("LINPD_PY_FUZZ_SEED", 20261126)))
    ap.add_argument("--petsc-cases", type=int, default=6)
    ap.add_argument("--petsc-pythonpath", default=None,
                    help="PYTHONPATH for the PETSc driver's interpreter ($LINPD_PETSC_PYTHON)")
    ap.add_argument("--case", type=int, default=None)
    args = ap.parse_args()
    inputs = scenes()
    strings = strings_of([d for _, d, _ in inputs])
    root = Path(tempfile.mkdtemp(prefix="linpd-pyfuzz-"))
    env = dict(os.environ, LINPD_MEMORY_GIB="2")
    counts, failures = {}, []
    t0 = time.monotonic()
    case = 0 if args.case is None else args.case
    petsc_left = args.petsc_cases if args.case is None else 0
    while True:
        if args.case is None and time.monotonic() - t0 > args.secs and petsc_left == 0:
            break
        rng = random.Random(args.seed * 1_000_003 + case)
        work = root / f"case-{case}"
        name, muts = make_case(rng, inputs, strings, work)
        petsc = args.case is None and time.monotonic() - t0 > args.secs and petsc_left > 0
        if petsc:
            petsc_left -= 1
            py = os.environ.get("LINPD_PETSC_PYTHON", "/usr/bin/python3")
            cmd = ["mpiexec", "-n", "2"] + (["--allow-run-as-root"] if os.geteuid() == 0 else [])
            cmd += ["--oversubscribe", py, "-m", "linpd.petsc", "scene.json", "--out", "out"]
            penv = dict(env)
            if args.petsc_pythonpath:
                # the runs' working directory is the case's: absolute entries only
                penv["PYTHONPATH"] = os.pathsep.join(
                    str(Path(p).resolve()) for p in args.petsc_pythonpath.split(os.pathsep) if p)
            code, err, timed_out, secs = run(cmd, work, penv)
        else:
            mode = "dict" if rng.random() < 0.5 else "file"
            code, err, timed_out, secs = run([sys.executable, "-c", CHILD, mode, "scene.json"], work, env)
        cls = classify(code, err, timed_out, work, petsc)
        key = ("petsc " if petsc else "python ") + cls
        counts[key] = counts.get(key, 0) + 1
        last = err.strip().splitlines()[-1] if err.strip() else ""
        if cls in FAILURES or args.case is not None:
            failures.append((case, name, muts, cls, last))
            print(f"case {case} ({name}; {'; '.join(muts)}): {cls} (exit {code}): {last}")
            print(f"  kept in {work}")
        else:
            shutil.rmtree(work, ignore_errors=True)
        case += 1
        if args.case is not None:
            break
    print(f"fuzz_entry: seed {args.seed}, {case} cases in {time.monotonic() - t0:.0f} s")
    for k in sorted(counts):
        print(f"  {k:40} {counts[k]}")
    if not failures:
        shutil.rmtree(root, ignore_errors=True)
    sys.exit(1 if any(f[3] in FAILURES for f in failures) else 0)


if __name__ == "__main__":
    main()
