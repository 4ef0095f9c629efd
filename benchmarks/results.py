"""Regenerates ``benchmarks/RESULTS.md`` from the benchmark scripts' own outputs.

Each section of ``SECTIONS`` is one script: ``run`` executes it (or the
sections ``--sections`` names) and stores its markdown under
``benchmarks/results/<name>.md`` (the suites also leave
their CSV and PNG files there); then every stored section is assembled, in
registry order, under a header naming the machine, the versions, the date and
the commit, after the hand-written ``benchmarks/results/notes.md``. A section
whose script is not in this checkout is skipped with a note. Nothing in
RESULTS.md is typed by hand except ``notes.md``.

    python benchmarks/results.py                      # run everything, then assemble
    python benchmarks/results.py --sections peers     # rerun one section, assemble all
    python benchmarks/results.py --assemble-only      # assemble what is stored
    python benchmarks/results.py --quick --results /tmp/r --output /tmp/R.md   # smoke test
    python benchmarks/results.py --pinned ...         # under taskset -c 0, stored as <name>_pinned
"""

from __future__ import annotations

import argparse
import datetime
import importlib.metadata
import os
import platform
import re
import subprocess
import sys
from typing import NamedTuple

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


class Section(NamedTuple):
    title: str
    script: str  # under benchmarks/
    args: tuple = ()  # "{out}" is replaced by the results folder
    fragment: str | None = None  # file (from the repo root; "{out}" as above) holding its markdown;
    # None: its standard output
    fence: bool = False  # stdout that is not markdown: shown as a code block


# One line per section; a new benchmark script is one more line here. The one-off
# experiments in benchmarks/archive/ are not sections (their README lists them).
SECTIONS = {
    "dense": Section("Dense detectors", "dense.py"),
    "bucket": Section("Bucket sort", "bucket.py", fence=True),
    "scaling": Section("Devices and batches", "scaling.py"),
    "paper_tests": Section(
        "Paper tests", "paper_tests.py", ("--out", "{out}"), "{out}/paper_tests.md"
    ),
    "peers": Section("Peers", "peers.py", ("--out", "{out}"), "{out}/peers.md"),
    "swept_peers": Section(
        "Peers: path crossing", "swept_peers.py", ("--out", "{out}"), "{out}/swept_peers.md"
    ),
    "time_vs_error": Section(
        "Time against error", "time_vs_error.py", ("--out", "{out}"), "{out}/time_vs_error.md"
    ),
    # 2d3f36b: 0.7.3's reused step, before 0.7.4 rewrote the skin check.
    "search_step": Section(
        "Search step",
        "search_step.py",
        ("--out", "{out}", "--against", "2d3f36b"),
        "{out}/search_step.md",
    ),
    "stability": Section("Stability", "stability.py", ("--out", "{out}")),
    "simulate": Section("Simulation", "simulate.py"),
    "size_scaling": Section(
        "Size scaling: time, memory and compile time against N and M",
        "size_scaling.py",
        ("--out", "{out}"),
        "{out}/size_scaling.md",
    ),
    "stages": Section("Where the bucket sort's time goes", "stages.py"),
    "compile_ops": Section("What a compile costs, kernel by kernel (issue 25)", "compile_ops.py"),
    "targets": Section(
        "Issue 25's targets: Search.closest against the numba grid",
        "targets.py",
        ("--out", "{out}"),
        "{out}/targets.md",
    ),
    "one_call": Section(
        "A plain call against the jitted step, small scenes (issue 25, target 2)", "one_call.py"
    ),
    "bodies": Section("Bodies, self-contact and a radius per slave", "bodies.py"),
    "friction": Section("Slip tracking, friction and smooth normals", "friction.py"),
    "cutting": Section(
        "Orthogonal cutting against Merchant and Kienzle",
        "cutting.py",
        ("--out", "{out}"),
        "{out}/cutting.md",
    ),
}
VERSIONED = (
    "jax",
    "jaxlib",
    "numpy",
    "scipy",
    "shapely",
    "matplotlib",
    "jax-md",
    "libigl",
    "numba",
    "ipctk",
)


def run_section(name: str, results: str, quick: bool, pinned: bool) -> str:
    """Runs one section's script; stores and returns its markdown (or why it was skipped)."""
    section = SECTIONS[name]
    script = os.path.join(HERE, section.script)
    stored = os.path.join(results, f"{name}{'_pinned' if pinned else ''}.md")
    if not os.path.exists(script):
        return f"`benchmarks/{section.script}` is not in this checkout: section skipped."
    # A pinned run keeps its CSV and PNG files apart from the unpinned one's.
    out = os.path.join(results, "pinned") if pinned else results
    # Relative to the repository root (the scripts run there), so the command
    # RESULTS.md shows can be rerun from any clone.
    out = os.path.relpath(out, ROOT)
    args = [arg.format(out=out) for arg in section.args] + (["--quick"] if quick else [])
    command = ["taskset", "-c", "0"] * pinned + [sys.executable, script, *args]
    shown = " ".join(["taskset -c 0"] * pinned + [f"python benchmarks/{section.script}", *args])
    print(f"running: {shown}", file=sys.stderr, flush=True)
    # This checkout's package first, even where another copy is installed.
    path = os.pathsep.join(filter(None, [ROOT, os.environ.get("PYTHONPATH")]))
    env = {**os.environ, "PYTHONPATH": path}
    done = subprocess.run(command, cwd=ROOT, env=env, capture_output=True, text=True, check=False)
    if done.returncode:
        body = f"`{shown}` failed (exit {done.returncode}):\n\n```\n{done.stderr[-3000:]}\n```"
    elif section.fragment:
        fragment = os.path.join(ROOT, section.fragment.format(out=out))
        with open(fragment) as stream:
            body = stream.read()
        if pinned:
            body = re.sub(r"\]\(([^)/]+\.png)\)", r"](pinned/\1)", body)
    else:
        body = f"```\n{done.stdout.strip()}\n```" if section.fence else done.stdout.strip()
    text = f"Command: `{shown}`\n\n{body.strip()}\n"
    os.makedirs(results, exist_ok=True)
    with open(stored, "w") as stream:
        stream.write(text)
    return text


def machine() -> list[str]:
    """Lines on the CPU, cores, affinity, memory, versions, date and commit."""
    cpu, memory = platform.processor() or platform.machine(), "unknown"
    try:
        with open("/proc/cpuinfo") as info:
            cpu = next(line.split(":", 1)[1].strip() for line in info if "model name" in line)
        with open("/proc/meminfo") as info:
            kib = int(next(line.split()[1] for line in info if line.startswith("MemTotal")))
            memory = f"{kib / 2**20:.0f} GiB"
    except (OSError, StopIteration):
        pass
    try:
        affinity = ",".join(map(str, sorted(os.sched_getaffinity(0))))
    except AttributeError:
        affinity = "unknown"
    versions = [f"python {platform.python_version()}"]
    for package in VERSIONED:
        try:
            versions.append(f"{package} {importlib.metadata.version(package)}")
        except importlib.metadata.PackageNotFoundError:
            versions.append(f"{package} not installed")
    commit = subprocess.run(
        ["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True
    ).stdout.strip()
    return [
        f"- Machine: {cpu}; {os.cpu_count()} cores, this process allowed {affinity}; {memory}.",
        f"- Versions: {', '.join(versions)}.",
        f"- Assembled {datetime.date.today().isoformat()} at commit {commit or 'unknown'}"
        " (each section names the command that produced it).",
    ]


def _demoted(body: str) -> str:
    """``body`` with its headings two levels down (under the section's), code blocks untouched."""
    lines, in_code = [], False
    for line in body.splitlines():
        in_code ^= line.startswith("```")
        if not in_code and re.match(r"#{1,4} ", line):
            line = "##" + line
        lines.append(line)
    return "\n".join(lines)


def assemble(results: str, output: str, notes: str) -> None:
    """Writes ``output`` from ``notes`` and every stored section, in registry order."""
    lines = ["# Benchmark results", "", *machine(), ""]
    folder = os.path.relpath(results, os.path.dirname(os.path.abspath(output)))
    if os.path.exists(notes):
        with open(notes) as stream:
            lines += [stream.read().strip(), ""]
    for name, section in SECTIONS.items():
        for suffix, how in (("", ""), ("_pinned", " (pinned to one core)")):
            stored = os.path.join(results, f"{name}{suffix}.md")
            if os.path.exists(stored):
                with open(stored) as stream:
                    body = stream.read().strip()
                body = _demoted(body)
                if "{out}" in section.args:
                    # Their pictures are linked by name, beside them in ``results``.
                    body = re.sub(r"!\[([^\]]*)\]\(([^):]+\.png)\)", rf"![\1]({folder}/\2)", body)
                lines += [f"## {section.title}{how}", "", body, ""]
            elif not suffix and not os.path.exists(os.path.join(HERE, section.script)):
                missing = f"`benchmarks/{section.script}` is not in this checkout."
                lines += [f"## {section.title}", "", missing, ""]
            elif not suffix:
                missing = f"Not run yet: `python benchmarks/results.py --sections {name}`."
                lines += [f"## {section.title}", "", missing, ""]
    with open(output, "w") as stream:
        stream.write("\n".join(lines))
    print(f"wrote {output}", file=sys.stderr)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sections", default=",".join(SECTIONS), help="sections to rerun")
    parser.add_argument("--assemble-only", action="store_true", help="run nothing")
    parser.add_argument("--quick", action="store_true", help="pass --quick to every script")
    parser.add_argument("--pinned", action="store_true", help="run under taskset -c 0")
    parser.add_argument("--results", default=os.path.join(HERE, "results"))
    parser.add_argument("--output", default=os.path.join(HERE, "RESULTS.md"))
    parser.add_argument("--notes", default=os.path.join(HERE, "results", "notes.md"))
    args = parser.parse_args(argv)
    names = args.sections.split(",")
    unknown = sorted(set(names) - set(SECTIONS))
    if unknown:
        parser.error(f"--sections: unknown {unknown}; expected some of {list(SECTIONS)}")
    if not args.assemble_only:
        for name in names:
            run_section(name, args.results, args.quick, args.pinned)
    assemble(args.results, args.output, args.notes)
    return 0


if __name__ == "__main__":
    sys.exit(main())
