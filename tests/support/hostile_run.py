"""The hostile run: fuzzed variants of the project's scenes through the ``gshade`` command.

    .venv/bin/python tests/support/hostile_run.py --count 752 --seed 1 --jobs 2 --timeout 60 \
        --memory-gb 4

Each variant (tests/support/fuzz_scenes.py; case i depends only on the seed and i) is written
into its own folder with a copy of scenes/data/, and run through

    gshade render VARIANT -o out.exr --width 160 --height 120 --spp 4
    gshade info VARIANT
    gshade continuity VARIANT

in subprocesses (``--jobs`` at a time), each with a wall-clock limit (``--timeout``) and a
memory limit (``--memory-gb``: an address-space limit, RLIMIT_AS, which normal renders fit in;
``--memory-mode rss`` polls the resident size instead; under RLIMIT_AS Dr.Jit/LLVM may die by
SIGSEGV where an allocation is refused, so a run killed by a signal is run again watching the
resident size, and counted as memory if that passes the limit; gshade's own limit,
GSHADE_MEMORY_LIMIT, is left as the environment sets it).  The command is the ``gshade`` console
entry point (``gshade.app.cli.console``) run by the same interpreter as ``--gshade``'s, with a
faulthandler stack dump on SIGUSR1 added; a run past its limit gets SIGUSR1 (where it was),
then SIGTERM (gshade's own cleanup), then SIGKILL 5 s later.  ``--plain`` runs the
``--gshade`` script itself (no stack at timeouts).  Every run is classified:

    exit 2 with one clean line     the contract: one line on stderr, no traceback
    exit 0, finite                 render: the EXR exists and every channel is finite
    traceback (exit 1)
    exit 2 with extra stderr lines warnings (or more) printed before the message
    still running after T s        killed (after a faulthandler dump, for the location)
    memory above N GB              peak RSS above N GB, or MemoryError / bad_alloc
    exit 0 with NaN/inf            in the EXR's channels (render), or printed (info, continuity)
    killed by a signal
    other exit                     any other exit status, or exit 0 without the EXR

and counted separately: clean messages that do not name the scene file, and failed runs that
left files in the variant's folder (runs ended by a signal, which cannot clean up, are only
shown).  Prints a markdown table, every run that is not clean (label and last stderr line)
and those runs grouped by cause (exception type and the gshade code location from the
traceback, the warning's location, or the stack at the timeout).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import resource
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections import Counter, defaultdict
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from fuzz_scenes import ROOT, cases, listing, probes, rss_of, write_variant

OUTCOMES = {
    "clean": "exit 2 with one clean line",
    "ok": "exit 0, finite",
    "traceback": "traceback (exit 1)",
    "extra": "exit 2 with extra stderr lines (warnings first)",
    "timeout": "still running after {timeout:g} s",
    "memory": "memory above {memory:g} GB",
    "nan": "exit 0 with NaN/inf (EXR, or printed)",
    "signal": "killed by a signal",
    "other": "other exit (status, or exit 0 without the EXR)",
}
COMMANDS = ("render", "info", "continuity")
MEMORY_SIGNS = re.compile(
    r"MemoryError|bad_alloc|out of memory|Cannot allocate memory|failed to allocate", re.I
)
FRAME = re.compile(r'File "([^"]+)", line (\d+),? in (\S+)')
WARNING = re.compile(r"^(.*?):(\d+): (\w*Warning): (.*)$")
NAN_TEXT = re.compile(r"(?<![\w.])[-+]?(nan|inf|infinity)(?![\w])", re.I)


def short_path(path: str) -> str:
    path = path.replace("\\", "/")
    for marker in ("/gshade/", "/site-packages/", "/lib/python3."):
        if marker in path:
            rest = path.split(marker, 1)[1]
            if marker == "/gshade/":
                return "gshade/" + rest
            return rest.split("/", 1)[-1] if marker == "/lib/python3." else rest
    return path


def shorten(text: str, limit: int = 160) -> str:
    text = " ".join(text.split())
    return text if len(text) <= limit else text[: limit - 1] + "…"


#: ``gshade`` as its console script runs it, plus a stack dump on SIGUSR1 (to stderr).
WRAPPER = (
    "import faulthandler, signal, sys; faulthandler.register(signal.SIGUSR1, all_threads=False); "
    "sys.argv[0] = 'gshade'; from gshade.app.cli import console; sys.exit(console())"
)


def gshade_argv(args) -> list[str]:
    """The command line that runs ``gshade``: the wrapper under the script's interpreter."""
    if args.plain:
        return [args.gshade]
    python = sys.executable
    try:
        first = Path(args.gshade).read_text(errors="replace").splitlines()[0]
        if first.startswith("#!") and "python" in first:
            python = first[2:].strip().split()[0]
    except (OSError, IndexError):
        pass
    return [python, "-c", WRAPPER]


def stop(pid: int) -> None:
    """SIGUSR1 (stack dump), SIGTERM (gshade's cleanup), SIGKILL after 5 s."""
    for sig, wait in ((signal.SIGUSR1, 0.5), (signal.SIGTERM, 5.0)):
        try:
            os.killpg(pid, sig)
        except ProcessLookupError:
            return
        deadline = time.monotonic() + wait
        while time.monotonic() < deadline:
            if os.waitid(os.P_PID, pid, os.WEXITED | os.WNOHANG | os.WNOWAIT) is not None:
                return
            time.sleep(0.05)
    try:
        os.killpg(pid, signal.SIGKILL)
    except ProcessLookupError:
        pass


def run_one(argv: list[str], cwd: Path, timeout: float, memory: int, mode: str) -> dict:
    """Run a command; its exit status (negative: signal), output, peak RSS and why it ended."""
    out_path, err_path = cwd / ".stdout", cwd / ".stderr"

    env = dict(os.environ, PYTHONFAULTHANDLER="1")  # a stack on fatal signals too
    with open(out_path, "wb") as out, open(err_path, "wb") as err:
        proc = subprocess.Popen(
            argv, cwd=cwd, stdout=out, stderr=err, stdin=subprocess.DEVNULL, env=env,
            start_new_session=True,
        )  # fmt: skip
        if mode == "as":  # not preexec_fn (unsafe with threads); Popen returns after exec,
            try:  # long before a scene is read
                resource.prlimit(proc.pid, resource.RLIMIT_AS, (memory, memory))
            except (ProcessLookupError, PermissionError):
                pass
        start = time.monotonic()
        killed = None
        peak = 0
        while True:
            pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
            if pid:
                break
            if mode == "rss":
                peak = max(peak, rss_of(proc.pid))
            over = mode == "rss" and peak > memory
            late = time.monotonic() - start > timeout
            if over or late:
                killed = "memory" if over else "timeout"
                stop(proc.pid)
                pid, status, usage = os.wait4(proc.pid, 0)
                break
            time.sleep(0.02)
        proc.returncode = os.waitstatus_to_exitcode(status)
    seconds = time.monotonic() - start
    stdout = out_path.read_bytes().decode("utf-8", "replace")
    stderr = err_path.read_bytes().decode("utf-8", "replace")
    out_path.unlink()
    err_path.unlink()
    return {
        "rc": proc.returncode,
        "stdout": stdout,
        "stderr": stderr,
        "peak_rss": max(peak, usage.ru_maxrss * 1024),
        "killed": killed,
        "seconds": seconds,
    }


def exr_finite(path: Path) -> tuple[bool, str]:
    import numpy as np

    from gshade.io.image import read_exr

    channels, _ = read_exr(path)
    bad = [k for k, c in channels.items() if not np.isfinite(c).all()]
    return not bad, ", ".join(bad)


def classify(command: str, run: dict, folder: Path, scene: Path, memory: int) -> dict:
    rc, stderr = run["rc"], run["stderr"]
    lines = [line for line in stderr.splitlines() if line.strip()]
    traceback = "Traceback (most recent call last)" in stderr
    info = {"detail": lines[-1] if lines else ""}
    if run["killed"] == "timeout":
        outcome = "timeout"
        info["detail"] = f"stopped after {run['seconds']:.0f} s (exit {rc})"
    elif run.get("as_crash"):
        outcome = "memory"
        name = signal.Signals(-rc).name if rc < 0 else rc
        info["detail"] = (
            f"{name} under RLIMIT_AS {memory / 2**30:g} GB; without it: RSS past "
            f"{run['as_crash'] / 2**30:.1f} GB"
        )
    elif (
        run["killed"] == "memory"
        or run["peak_rss"] > memory
        or (rc not in (0, 2) and MEMORY_SIGNS.search(stderr))
    ):
        outcome = "memory"
        info["detail"] = f"peak RSS {run['peak_rss'] / 2**30:.1f} GB, exit {rc}: " + last_line(
            lines
        )
    elif rc < 0:
        outcome = "signal"
        info["detail"] = f"signal {-rc} ({signal.Signals(-rc).name}): " + last_line(lines)
    elif traceback:
        outcome = "traceback"
    elif rc == 2:
        outcome = "clean" if len(lines) == 1 else "extra"
        if outcome == "clean" and scene.name not in lines[0]:
            info["unnamed"] = True
    elif rc == 0:
        outcome = "ok"
        if command == "render":
            exr = folder / "out.exr"
            if not exr.is_file():
                outcome, info["detail"] = "other", "exit 0 without out.exr"
            else:
                try:
                    finite, bad = exr_finite(exr)
                except Exception as exc:  # an unreadable EXR is a finding
                    finite, bad = False, f"unreadable: {type(exc).__name__}: {exc}"
                if not finite:
                    outcome, info["detail"] = "nan", f"EXR channels not finite: {bad}"
        elif NAN_TEXT.search(run["stdout"]):
            hits = [ln for ln in run["stdout"].splitlines() if NAN_TEXT.search(ln)]
            outcome, info["detail"] = "nan", f"printed: {hits[0].strip()}"
    else:
        outcome = "other"
        info["detail"] = f"exit {rc}: " + info["detail"]
    info["outcome"] = outcome
    info["cause"] = cause(outcome, stderr, lines)
    return info


def last_line(lines: list[str]) -> str:
    """The last stderr line that is not part of a faulthandler dump."""
    for line in reversed(lines):
        text = line.strip()
        if not re.match(
            r"(File \"|Extension modules:|Current thread|Thread 0x|Fatal Python)", text
        ):
            return line
    return ""


def _exception_at(block: str) -> str:
    """ "Type @ innermost gshade frame" of one printed traceback (innermost frame last)."""
    frames = FRAME.findall(block)
    ours = [f for f in frames if "/gshade/" in f[0]]
    last = re.compile(r"^[\w.]+(Error|Exception|Interrupt|Exit)\b")
    exc = next((ln for ln in reversed(block.splitlines()) if last.match(ln)), "?")
    kind = exc.split(":", 1)[0].rsplit(".", 1)[-1]
    where = ours[-1] if ours else (frames[-1] if frames else None)
    location = f"{short_path(where[0])}:{where[1]} {where[2]}" if where else "?"
    if kind == "RuntimeError" and "(see above)" not in exc:  # Dr.Jit / Mitsuba: say which
        kind += f" ({shorten(exc.split(':', 1)[-1], 60)})"
    return f"{kind} @ {location}"


def cause(outcome: str, stderr: str, lines: list[str]) -> str:
    """Exception type and gshade code location (tracebacks, faulthandler dumps, warnings)."""
    if outcome in ("clean", "ok"):
        return ""
    if outcome == "extra":
        for line in lines[:-1]:
            m = WARNING.match(line)
            if m:
                where = f"{short_path(m.group(1))}:{m.group(2)}"
                return f"{m.group(3)} @ {where}: {shorten(m.group(4), 60)}"
        return "extra line: " + shorten(lines[0], 80)
    if outcome in ("nan", "other"):
        return outcome
    frames = FRAME.findall(stderr)
    if "Traceback (most recent call last)" in stderr:
        # the last traceback printed (the one that ended the program), and the first one if
        # it was chained (e.g. Dr.Jit's "error while performing a custom operation (see above)")
        blocks = stderr.split("Traceback (most recent call last)")[1:]
        text = " <- ".join(_exception_at(b) for b in {blocks[-1]: 0, blocks[0]: 0})
        return text
    # faulthandler dump (timeout, memory, signal): innermost frame first; the first dump
    block = re.split(r"\n(?=Current thread|Thread 0x|Fatal Python)", stderr)
    dumps = [b for b in block if FRAME.search(b)]
    frames = FRAME.findall(dumps[0]) if dumps else frames
    ours = [f for f in frames if "/gshade/" in f[0]]
    where = ours[0] if ours else (frames[0] if frames else None)
    location = f"{short_path(where[0])}:{where[1]} {where[2]}" if where else "no Python stack"
    return f"{outcome} @ {location}"


def run_variant(case, folder: Path, args, memory: int) -> list[dict]:
    scene = write_variant(folder, case)
    records = []
    for command in COMMANDS:
        argv = [*gshade_argv(args), command, scene.name]
        if command == "render":
            argv += ["-o", "out.exr", "--width", str(args.width), "--height", str(args.height)]
            argv += ["--spp", str(args.spp)]
        before = listing(folder)
        run = run_one(argv, folder, args.timeout, memory, args.memory_mode)
        after = listing(folder)
        if args.memory_mode == "as" and run["rc"] < 0 and run["killed"] is None:
            # Dr.Jit / LLVM may crash (SIGSEGV) instead of raising when RLIMIT_AS refuses an
            # allocation: run it again watching the resident size, to tell memory from a crash
            again = run_one(argv, folder, args.timeout, memory, "rss")
            if again["killed"] == "memory" or again["peak_rss"] > memory:
                run["as_crash"] = again["peak_rss"]
            for name in set(listing(folder)) - set(after):  # what the second run wrote
                (folder / name).unlink()
        info = classify(command, run, folder, scene, memory)
        if run["rc"] != 0 and after != before:
            changed = sorted(k for k in after if after[k] != before.get(k)) or ["(files removed)"]
            # a process ended by a signal (SIGKILL, SIGSEGV) cannot clean up: shown, not counted
            info["files_left" if run["rc"] >= 0 else "files_left_by_signal"] = changed
        records.append(
            {
                "label": case.label,
                "command": command,
                "rc": run["rc"],
                "seconds": round(run["seconds"], 2),
                "peak_rss_mb": run["peak_rss"] // 2**20,
                "stderr_lines": len([ln for ln in run["stderr"].splitlines() if ln.strip()]),
                **info,
            }
        )
    if not args.keep:
        shutil.rmtree(folder, ignore_errors=True)
    return records


def report(records: list[dict], args, wall: float) -> str:
    names = {k: v.format(timeout=args.timeout, memory=args.memory_gb) for k, v in OUTCOMES.items()}
    counts = {c: Counter(r["outcome"] for r in records if r["command"] == c) for c in COMMANDS}
    total = Counter(r["outcome"] for r in records)
    out = [
        f"Hostile run: {args.count} variants (seed {args.seed}) x {len(COMMANDS)} commands = "
        f"{len(records)} runs; render {args.width}x{args.height}, {args.spp} spp; limits "
        f"{args.timeout:g} s, {args.memory_gb:g} GB ({args.memory_mode}); {args.jobs} jobs; "
        f"wall {wall / 60:.1f} min",
        "",
        "| outcome | " + " | ".join(COMMANDS) + " | all |",
        "|---|" + "---:|" * (len(COMMANDS) + 1),
    ]
    for key, name in names.items():
        out.append(
            f"| {name} | "
            + " | ".join(str(counts[c][key]) for c in COMMANDS)
            + f" | {total[key]} |"
        )
    unnamed = Counter(r["command"] for r in records if r.get("unnamed"))
    left = Counter(r["command"] for r in records if r.get("files_left"))
    out.append(
        "| clean messages not naming the scene file | "
        + " | ".join(str(unnamed[c]) for c in COMMANDS)
        + f" | {sum(unnamed.values())} |"
    )
    out.append(
        "| failed runs that left files behind | "
        + " | ".join(str(left[c]) for c in COMMANDS)
        + f" | {sum(left.values())} |"
    )
    bad = [
        r
        for r in records
        if r["outcome"] not in ("clean", "ok") or r.get("unnamed") or r.get("files_left")
    ]
    out += ["", f"## Runs that are not clean ({len(bad)})", ""]
    for r in bad:
        what = r["outcome"]
        if r.get("unnamed"):
            what = "clean, does not name the scene file"
        if r.get("files_left"):
            what += f"; left {', '.join(r['files_left'])}"
        if r.get("files_left_by_signal"):
            what += f"; the signal left {', '.join(r['files_left_by_signal'])}"
        why = f" ({r['cause']})" if r["outcome"] in ("timeout", "memory", "signal") else ""
        out.append(f"- {r['command']} {r['label']}: [{what}]{why} {shorten(r['detail'])}")
    groups = defaultdict(list)
    for r in records:
        if r["outcome"] not in ("clean", "ok"):
            groups[(r["outcome"], r["cause"])].append(r)
        if r.get("unnamed"):
            groups[("clean", "does not name the scene file")].append(r)
    out += ["", "## Grouped by cause", "", "| outcome | cause | runs | commands | example |"]
    out.append("|---|---|---:|---|---|")
    for (outcome, why), rs in sorted(groups.items(), key=lambda kv: (kv[0][0], -len(kv[1]))):
        commands = ",".join(sorted({r["command"] for r in rs}))
        example = rs[0]
        out.append(
            f"| {outcome} | {why.replace('|', '/')} | {len(rs)} | {commands} | "
            f"{example['label']}: {shorten(example['detail'], 100).replace('|', '/')} |"
        )
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--count", type=int, default=752)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--timeout", type=float, default=60.0, help="seconds per command")
    parser.add_argument("--memory-gb", type=float, default=4.0)
    parser.add_argument("--memory-mode", choices=("as", "rss"), default="as")
    parser.add_argument("--width", type=int, default=160)
    parser.add_argument("--height", type=int, default=120)
    parser.add_argument("--spp", type=int, default=4)
    default = ROOT / ".venv" / "bin" / "gshade"
    parser.add_argument("--gshade", default=str(default) if default.exists() else "gshade")
    parser.add_argument("--plain", action="store_true", help="run --gshade itself (no stacks)")
    parser.add_argument("--workdir", help="folder for the variants (default: a temporary one)")
    parser.add_argument("--keep", action="store_true", help="keep the variants' folders")
    parser.add_argument("--json", help="write every run's record (JSON lines) here")
    parser.add_argument("--only", type=int, nargs="*", help="run only these case numbers")
    parser.add_argument(
        "--probes", action="store_true", help="also the fixed probes (P01-...) of fuzz_scenes"
    )
    args = parser.parse_args(argv)
    args.gshade = shutil.which(args.gshade) or args.gshade
    memory = int(args.memory_gb * 2**30)
    work = Path(args.workdir or tempfile.mkdtemp(prefix="gshade-hostile-"))
    work.mkdir(parents=True, exist_ok=True)
    todo = list(enumerate(cases(args.count, args.seed)))
    if args.only is not None:
        todo = [(i, c) for i, c in todo if i in set(args.only)]
    if args.probes:
        todo = [(-n, c) for n, c in enumerate(probes(), start=1)] + todo
    start = time.monotonic()
    records: list[dict] = []
    lock = threading.Lock()
    done = 0

    def task(item):
        nonlocal done
        i, case = item
        result = run_variant(case, work / (f"v{i:04d}" if i >= 0 else f"p{-i:02d}"), args, memory)
        with lock:
            records.extend(result)
            done += 1
            if done % 25 == 0 or done == len(todo):
                bad = sum(r["outcome"] not in ("clean", "ok") for r in records)
                print(f"[{time.monotonic() - start:6.0f} s] {done}/{len(todo)} variants, "
                      f"{bad} runs not clean", file=sys.stderr, flush=True)  # fmt: skip
        return result

    with ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        list(pool.map(task, todo))
    wall = time.monotonic() - start
    order = {c.label: i for i, c in todo}
    records.sort(key=lambda r: (order[r["label"]], COMMANDS.index(r["command"])))
    if args.json:
        with open(args.json, "w", encoding="utf-8") as f:
            for r in records:
                f.write(json.dumps(r, ensure_ascii=True) + "\n")
    args.count = len(todo)
    print(report(records, args, wall))
    if not args.keep and not args.workdir:
        shutil.rmtree(work, ignore_errors=True)
    return 0 if all(r["outcome"] in ("clean", "ok") for r in records) else 1


if __name__ == "__main__":
    sys.exit(main())
