"""The orthogonal cutting simulation set against Merchant, Kienzle and its own mass scaling.

Runs ``jaxcontact.sim.cutting`` (AISI 1045, 100 m/min, h = 0.10 mm, rake 0°,
mu = 0.3 capped at half the shear flow stress, 4 elements through h, mass
scaled 400x) as ``jaxcontact demo`` does, then the same cut at half the
mass scaling (200x: the stable step shorter by sqrt 2, the steps more by as
much), and writes ``benchmarks/results/cutting.md`` and ``cutting.json``:

* the steady cutting and thrust forces (means over the last 40 % of the
  steps, N per mm of width), the chip's thickness ratio and shear angle
  (from the chip's geometry), the friction angle (from the forces);
* **Merchant** (``sim.machining``): the shear angle 45 + gamma/2 - beta/2 and
  the forces of the force circle for the friction angle the run gives, with
  the shear stress tau_s = sigma_JC / sqrt 3 at the steady chip's plastic
  strain and temperature and the primary shear zone's strain rate;
* **Kienzle** for Ck45: k_c1.1 = 2220 N/mm², m_c = 0.14 (König and Klocke),
  and the band down to k_c1.1 = 1500 N/mm² that handbooks span;
* **mass scaling**: the forces of both runs and their difference.

A published orthogonal-cutting experiment on AISI 1045 is not in this
comparison: the data sets found (Klippel et al. 2024, Int. J. Adv. Manuf.
Technol. 135, 2871-2908, Ck45 with open data; the CIRP benchmark of Ivester
et al. 2000) could not be read from this machine, and no number is quoted
from memory. The results file says so.

    python benchmarks/cutting.py            # both runs, about 3 min on 2 cores
    python benchmarks/results.py --sections cutting   # the same, into RESULTS.md
    python benchmarks/cutting.py --fine     # and a third at half the element size (slow)
"""

from __future__ import annotations

import argparse
import json
import pathlib
import platform
import sys
import time

from jaxcontact.sim import cutting

RESULTS = pathlib.Path(__file__).parent / "results"


def measure(cut: cutting.Cutting, label: str) -> dict:
    started = time.perf_counter()
    model, state, record, frames, seconds = cutting.run(cut, 0.0, cutting.MU)
    summary = cutting.summary(model, state, record, frames, seconds, 0.0, cutting.MU)
    summary["detection_share"] = cutting.detection_share(model, state, 0.0, cutting.MU)
    summary["label"] = label
    summary["wall_s"] = time.perf_counter() - started
    summary["element_mm"] = cut.element
    summary["dropped_own_contacts"] = int(record.dropped.sum())
    print(
        f"{label}: F_c {summary['cutting_force_N_per_mm']:.1f} N/mm, "
        f"F_t {summary['thrust_force_N_per_mm']:.1f} N/mm, "
        f"chip ratio {summary['chip_thickness_ratio']:.2f}, "
        f"{summary['steps']} steps in {summary['wall_s']:.0f} s",
        file=sys.stderr,
        flush=True,
    )
    return summary


def markdown_table(runs: list[dict], rows) -> str:
    """A column per run (headed by its ``label``), a row per ``(name, key,
    format)`` of ``rows``; a value of None reads "never"."""
    head = "| | " + " | ".join(run["label"] for run in runs) + " |"
    lines = [head, "|---" * (len(runs) + 1) + "|"]
    for name, key, form in rows:
        cells = ("never" if run[key] is None else form.format(run[key]) for run in runs)
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def table(runs: list[dict]) -> str:
    rows = [
        ("cutting force F_c (N/mm)", "cutting_force_N_per_mm", "{:.1f}"),
        ("thrust force F_t (N/mm)", "thrust_force_N_per_mm", "{:.1f}"),
        ("chip thickness ratio h_c / h", "chip_thickness_ratio", "{:.2f}"),
        ("shear angle from the chip (°)", "shear_angle_deg", "{:.1f}"),
        ("friction angle from the forces (°)", "friction_angle_deg", "{:.1f}"),
        ("chip plastic strain (median)", "chip_plastic_strain", "{:.2f}"),
        ("chip temperature (°C, median)", "chip_temperature_C", "{:.0f}"),
        ("shear zone strain rate (1/s)", "shear_zone_strain_rate_per_s", "{:.2g}"),
        ("Merchant: tau_s (MPa)", "merchant_shear_stress_MPa", "{:.0f}"),
        ("Merchant: shear angle (°)", "merchant_shear_angle_deg", "{:.1f}"),
        ("Merchant: F_c (N/mm)", "merchant_cutting_force_N_per_mm", "{:.1f}"),
        ("Merchant: F_t (N/mm)", "merchant_thrust_force_N_per_mm", "{:.1f}"),
        ("Kienzle (Ck45): F_c (N/mm)", "kienzle_cutting_force_N_per_mm", "{:.1f}"),
        ("deepest penetration / element", "max_penetration_over_element", "{:.3f}"),
        ("eroded elements", "eroded_elements", "{}"),
        ("own contacts left out (deeper than 0.25 element)", "dropped_own_contacts", "{}"),
        ("nodes", "nodes", "{}"),
        ("steps", "steps", "{}"),
        ("steps per second (the first compile included)", "steps_per_second", "{:.0f}"),
        ("contact detection's share of a step", "detection_share", "{:.2f}"),
    ]
    return markdown_table(runs, rows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--fine", action="store_true", help="also run at half the element size")
    parser.add_argument(
        "--out", default=str(RESULTS), help="folder for cutting.md and cutting.json"
    )
    args = parser.parse_args()
    default = cutting.Cutting()
    runs = [
        measure(default, f"default ({default.mass_scaling:.0f}x mass)"),
        measure(
            cutting.Cutting(mass_scaling=default.mass_scaling / 2),
            f"half the scaling ({default.mass_scaling / 2:.0f}x)",
        ),
    ]
    if args.fine:
        runs.append(measure(cutting.Cutting(element=default.element / 2), "half the element"))
    base, half = runs[0], runs[1]
    low, high = base["kienzle_band_N_per_mm"]
    change = {
        key: half[key] / base[key] - 1
        for key in ("cutting_force_N_per_mm", "thrust_force_N_per_mm", "chip_thickness_ratio")
    }
    cpu = platform.processor() or platform.machine()
    text = f"""`python benchmarks/cutting.py` ({cpu}, float32; one
run of each; {time.strftime("%Y-%m-%d")}). Cut: 100 m/min, h = 0.10 mm, rake 0°, clearance 7°,
edge radius 2 µm, mu = {cutting.MU} capped at half of A/sqrt 3 (Zorev's sticking zone), plane
strain, {base["element_mm"] * 1000:.0f} µm elements (h/4), {default.travel} mm of travel.
Forces per mm of width, means over the last 40 % of the steps.

{table(runs)}

Kienzle's band for Ck45 at h = 0.10 mm: {low:.0f} to {high:.0f} N/mm (k_c1.1 from 1500 to
2220 N/mm², m_c = 0.14). The simulated F_c is {base["cutting_force_N_per_mm"] / high:.2f} of
Kienzle's tabulated value; Merchant's F_c for the run's own friction angle is
{base["merchant_cutting_force_N_per_mm"] / base["cutting_force_N_per_mm"]:.2f} of the simulated.

Mass scaling: halving it changed F_c by {100 * change["cutting_force_N_per_mm"]:+.1f} %, F_t by
{100 * change["thrust_force_N_per_mm"]:+.1f} % and the chip ratio by
{100 * change["chip_thickness_ratio"]:+.1f} %.

A published experiment is not compared here: the AISI 1045 data sets found (Klippel et al. 2024,
Int. J. Adv. Manuf. Technol. 135, 2871-2908, open Ck45 data; Ivester et al. 2000, the CIRP
benchmark) could not be read from this machine, and no measured number is quoted from memory.
"""
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "cutting.md").write_text(text)
    (out / "cutting.json").write_text(json.dumps(runs, indent=2))


if __name__ == "__main__":
    main()
