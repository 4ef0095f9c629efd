"""Chip curl: what it takes for the chip to curl and land on the workpiece, measured.

Runs ``jaxcontact.sim.cutting`` at 100 m/min, h = 0.10 mm, rake 0°, mu = 0.3 (the
demo's cut) over 3.2 mm of travel with 1.5 mm of uncut workpiece left ahead of
the tool, on the coarse mesh (2 elements through h, 50 µm), twice:

* **with a chip breaker** (``jaxcontact demo --curl``): a backwall 0.25 mm up
  the rake face, turned 30° towards the chip, 0.5 mm long (an obstruction-type
  breaker: the tool's geometry bends the chip);
* **with the plain rake face** (0.6 mm long), all else the same.

and, with ``--fine``, the default mesh (4 elements through h, 25 µm) over
1.5 mm of travel, past the 0.6 mm the demo runs, to show where that mesh's
run breaks down.

For each run it reports the travel at which the chip first touched the
workpiece (or itself) away from the edge (``Record.landed``: an own contact
farther than two uncut thicknesses from the edge's lowest point), the forces
(means over the last 40 % of the steps, N per mm of width), the chip ratio,
the deepest penetration into the tool or the workpiece's own outline over the
element, eroded elements and the travel at the first erosion. Writes
``chip_curl.md``, ``chip_curl.json`` and the last frame of each run as
``chip_curl_<label>.png`` (the demo's picture).

    python benchmarks/chip_curl.py             # two runs, about 8 min on 2 cores
    python benchmarks/chip_curl.py --fine      # and the default mesh over 1.5 mm (4 min more)
"""

from __future__ import annotations

import argparse
import json
import pathlib
import platform
import sys
import time
import warnings

import numpy as np

from jaxcontact.sim import cutting, cutting_demo

RESULTS = pathlib.Path(__file__).parent / "results"
CURL = cutting_demo.CURL


def markdown_table(runs: list[dict], rows) -> str:
    """A column per run (headed by its ``label``), a row per ``(name, key,
    format)`` of ``rows``; a value of None reads "never"."""
    head = "| | " + " | ".join(run["label"] for run in runs) + " |"
    lines = [head, "|---" * (len(runs) + 1) + "|"]
    for name, key, form in rows:
        cells = ("never" if run[key] is None else form.format(run[key]) for run in runs)
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def measure(cut: cutting.Cutting, label: str, out: pathlib.Path, pictures: bool) -> dict:
    started = time.perf_counter()
    model, state, record, frames, seconds = cutting.run(cut, 0.0, cutting.MU, chunks=40)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # a run with no steady chip: NaN
        summary = cutting.summary(model, state, record, frames, seconds, 0.0, cutting.MU)
    eroded = np.flatnonzero(np.asarray(record.eroded) > 0)
    summary.update(
        label=label,
        element_um=cut.element * 1000,
        travel_mm=cut.travel,
        breaker=cut.breaker,
        first_erosion_at_travel_mm=(
            cutting.travel_at(model, int(eroded[0])) if eroded.size else None
        ),
        own_depth_over_element=float(np.max(record.own_depth)) / cut.element,
        wall_s=time.perf_counter() - started,
    )
    if pictures:
        import matplotlib

        matplotlib.use("Agg")
        path = out / f"chip_curl_{label.split()[0]}.png"
        cutting_demo.draw_chip(model, frames[-1], 0.0, cutting.MU, str(path))
    print(
        f"{label}: lands at {summary['chip_lands_at_travel_mm']} mm, "
        f"F_c {summary['cutting_force_N_per_mm']:.1f} N/mm, "
        f"eroded {summary['eroded_elements']}, {summary['steps']} steps "
        f"in {summary['wall_s']:.0f} s",
        file=sys.stderr,
        flush=True,
    )
    return summary


def table(runs: list[dict]) -> str:
    rows = [
        ("elements (µm)", "element_um", "{:.0f}"),
        ("travel (mm)", "travel_mm", "{:.1f}"),
        ("the chip lands on the workpiece at travel (mm)", "chip_lands_at_travel_mm", "{:.2f}"),
        ("nodes touching on landing (most at once)", "chip_landing_contacts_max", "{}"),
        ("cutting force F_c (N/mm)", "cutting_force_N_per_mm", "{:.1f}"),
        ("thrust force F_t (N/mm)", "thrust_force_N_per_mm", "{:.1f}"),
        ("chip thickness ratio h_c / h", "chip_thickness_ratio", "{:.2f}"),
        (
            "deepest penetration, tool or own outline / element",
            "max_penetration_over_element",
            "{:.3f}",
        ),
        ("deepest own contact / element", "own_depth_over_element", "{:.3f}"),
        ("eroded elements", "eroded_elements", "{}"),
        ("first erosion at travel (mm)", "first_erosion_at_travel_mm", "{:.2f}"),
        ("nodes", "nodes", "{}"),
        ("steps", "steps", "{}"),
        ("wall time, compile included (s)", "wall_s", "{:.0f}"),
    ]
    return markdown_table(runs, rows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--fine", action="store_true", help="also the default mesh over 1.5 mm")
    parser.add_argument("--no-pictures", action="store_true", help="tables only")
    parser.add_argument("--out", default=str(RESULTS), help="folder for chip_curl.md and .json")
    args = parser.parse_args()
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    coarse = dict(element=CURL["element"], travel=CURL["travel"], ahead=CURL["ahead"])
    land, angle, length = CURL["breaker"]
    pictures = not args.no_pictures
    runs = [
        measure(cutting.Cutting(breaker=CURL["breaker"], **coarse), "breaker", out, pictures),
        measure(cutting.Cutting(**coarse), "plain rake face", out, pictures),
    ]
    if args.fine:
        runs.append(measure(cutting.Cutting(travel=1.5), "default mesh, 1.5 mm", out, pictures))
    cpu = platform.processor() or platform.machine()
    text = f"""`python benchmarks/chip_curl.py{" --fine" if args.fine else ""}` ({cpu}, float32;
one run of each; {time.strftime("%Y-%m-%d")}). Cut: 100 m/min, h = 0.10 mm, rake 0°, mu =
{cutting.MU} capped at half of A/sqrt 3, mass scaling {cutting.Cutting().mass_scaling:.0f}x,
{CURL["ahead"]} mm of uncut workpiece left ahead of the tool. The breaker: a backwall {land} mm
up the rake face, turned {angle:.0f}° towards the chip, {length} mm long. "Lands" is the
first own contact farther than {cutting.LANDING:g} uncut thicknesses from the edge
(``Record.landed``). Forces per mm of width, means over the last 40 % of the steps.

{table(runs)}
"""
    if pictures:
        text += (
            "\n"
            + "\n".join(
                f"![{run['label']}](results/chip_curl_{run['label'].split()[0]}.png)"
                for run in runs
            )
            + "\n"
        )
    (out / "chip_curl.md").write_text(text)
    (out / "chip_curl.json").write_text(json.dumps(runs, indent=2, default=str))
    print(text)


if __name__ == "__main__":
    main()
