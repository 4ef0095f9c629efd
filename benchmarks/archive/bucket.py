"""Bucket sort against the dense detectors and the CPU baselines a user would write.

Every figure is measured in one process, the baselines beside the library on
the same inputs: float32, jit, compile time apart, median and 10-90 percentile
spread of repeated runs ended by ``block_until_ready``. Each answer is checked
against ``all_to_all`` (or ``swept``) in float64 and its mismatches reported.
"bucket_sort (sized)" and "bucket_swept (sized)" are the bucket sorts with
their ``Sizes`` measured outside the timer (``jaxcontact._pipeline.sizes.measure``)
and the whole search, broad phase included, inside it; the one-call
``bucket_sort`` would measure them again at every call.

    python benchmarks/bucket.py               # all sections, a few minutes
    taskset -c 0 python benchmarks/bucket.py  # pinned to one core
    python benchmarks/bucket.py --quick       # small sizes, a smoke test

Sections: the cutting scene with the tool in the workpiece and clear of it
(with block sizes and narrow phases compared), the rough-die scene (cell
sizes compared; peak memory from XLA's own buffer accounting), the paper's
Tests 1 and 2 at 82,369 nodes, and reuse of candidates with a skin (the
internal sized search given candidates, and the public ``Search.closest``
with a reused state).
"""

from __future__ import annotations

import argparse
import functools
import pathlib
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2]))  # the repo root: benchmarks.*

import jax
import jax.numpy as jnp
import numpy as np

from benchmarks.harness._run import sized_contact, sized_crossing
from benchmarks.harness.internals import _bucket, measure
from benchmarks.harness.timing import pinned_note, time_call
from benchmarks.peer_codes.baselines import (
    kdtree_pairs_project,
    kdtree_project,
    numpy_box_then_dense,
)
from jaxcontact import Search, all_to_all, swept
from jaxcontact.scenes import cutting_scene, paper_scene, rough_die_scene

ROWS: list[tuple] = []


def report(section, method, nodes, segments, timing, compile_s, check, baseline_ms=None):
    ms = timing.median_s * 1e3
    ratio = "" if baseline_ms is None else f"{baseline_ms / ms:.1f}x"
    ROWS.append(
        (
            section,
            method,
            f"{nodes:,}",
            f"{segments:,}",
            f"{ms:.3f}",
            f"{timing.p10_s * 1e3:.3f}-{timing.p90_s * 1e3:.3f}",
            ratio,
            "" if compile_s is None else f"{compile_s:.2f}",
            check,
        )
    )
    print(" | ".join(ROWS[-1]), flush=True)


def mismatches(contact, reference) -> str:
    """Rows whose segment or found flag differs from the float64 reference.

    ``contact`` is ``(segment, found)`` or a peer's ``(segment, gap, found)``.
    """
    segment = np.asarray(contact[0])
    found = np.asarray(contact[-1])
    wrong = (segment != np.asarray(reference.segment)) | (found != np.asarray(reference.found))
    return f"{int(wrong.sum())} of {int(np.asarray(reference.found).sum())} found differ"


def reference_contact(scene, radius):
    nodes = scene.surface.nodes.astype(jnp.float64)
    x64 = scene.x.astype(jnp.float64)
    return jax.jit(all_to_all)(x64, scene.surface._replace(nodes=nodes), radius=radius)


# ----------------------------------------------------------------------------
# CPU baselines: the peers of jaxcontact/bench/baselines.py, shared with peers.py.


def differ_from_kdtree(x, start, end, segment, kd_segment) -> str:
    """Rows whose segment differs from cKDTree's, and how many of them are ties.

    A tie: both segments found, at the same float64 distance to within 1e-6
    of the radius scale (a vertex shared by neighbours: jaxcontact gives it to
    the face the slave is outside of, cKDTree's lexsort to the lower index).
    """
    rows = np.flatnonzero(segment != kd_segment)
    both = rows[(segment[rows] >= 0) & (kd_segment[rows] >= 0)]

    def distance(k):
        a, b, p = start[k].astype(float), end[k].astype(float), x[both].astype(float)
        d = b - a
        t = np.clip(np.einsum("pk,pk->p", p - a, d) / np.einsum("pk,pk->p", d, d), 0, 1)
        return np.linalg.norm(p - a - t[:, None] * d, axis=1)

    gap = np.abs(distance(segment[both]) - distance(kd_segment[both]))
    ties = int((gap <= 1e-6 * max(1.0, float(np.abs(x).max()))).sum())
    return f"{rows.size} rows differ from cKDTree, {ties} of them equal-distance ties"


def write_floor(x):
    """The least any detector returning N rows must do: read x once, write N empty rows."""
    zeros = jnp.zeros(x.shape[:1], x.dtype)
    false = jnp.zeros(x.shape[:1], bool)
    return (
        zeros + jnp.max(x),
        zeros,
        jnp.full(x.shape[:1], -1, jnp.int32),
        jnp.zeros_like(x),
        jnp.zeros_like(x),
        false,
        false,
    )


# ----------------------------------------------------------------------------


def endpoints(surface):
    nodes = np.asarray(surface.nodes)
    segments = np.asarray(surface.segments)
    return nodes[segments[:, 0]], nodes[segments[:, 1]]


def time_bucket(scene, radius, sizes, repeats):
    detect = sized_contact(radius, sizes)
    timing = time_call(detect, scene.x, scene.surface, repeats=repeats)
    result = detect(scene.x, scene.surface)
    return timing, result


def cutting_section(num_nodes, repeats, quick):
    for x_tip in (18.0, 20.5):
        scene = cutting_scene(num_nodes, x_tip)
        radius = scene.radius
        section = f"cutting x_tip={x_tip}"
        reference = reference_contact(scene, radius)
        dense = jax.jit(functools.partial(all_to_all, radius=radius))
        timing = time_call(dense, scene.x, scene.surface, repeats=repeats)
        dense_ms = timing.median_s * 1e3
        result = dense(scene.x, scene.surface)
        report(
            section,
            "all_to_all",
            num_nodes,
            20,
            timing,
            timing.compile_s,
            mismatches((result.segment, result.found), reference),
        )
        floor = time_call(jax.jit(write_floor), scene.x, repeats=repeats)
        report(
            section, "floor: read x, write N empty rows", num_nodes, 20, floor, None, "", dense_ms
        )
        start, end = endpoints(scene.surface)
        x = np.asarray(scene.x)
        numpy_timing = time_call(numpy_box_then_dense, x, start, end, radius, repeats=repeats)
        report(
            section,
            "NumPy box-then-dense",
            num_nodes,
            20,
            numpy_timing,
            None,
            mismatches(numpy_box_then_dense(x, start, end, radius), reference),
            dense_ms,
        )
        block_sizes = (64,) if quick else (32, 64, 128, 256)
        for block_size in block_sizes:
            for use_cells in (False, True) if block_size == 64 else (False,):
                sizes = measure(
                    scene.x,
                    scene.surface,
                    radius=radius,
                    block_size=block_size,
                    use_cells=use_cells,
                )
                timing, result = time_bucket(scene, radius, sizes, repeats)
                method = f"bucket_sort (sized) block={block_size}" + (" cells" if use_cells else "")
                report(
                    section,
                    method,
                    num_nodes,
                    20,
                    timing,
                    timing.compile_s,
                    mismatches((result.segment, result.found), reference),
                    dense_ms,
                )
                ROWS[-1] = ROWS[-1][:-1] + (
                    f"{ROWS[-1][-1]}; vs NumPy {numpy_timing.median_s / timing.median_s:.1f}x",
                )


def rough_die_section(sizes, repeats):
    for num_nodes, num_segments in sizes:
        scene = rough_die_scene(num_nodes, num_segments)
        radius = scene.radius
        section = f"rough die {num_nodes:.0e} x {num_segments:.0e}"
        reference = None
        if num_nodes * num_segments <= 2e9:
            reference = reference_contact(scene, radius)
        start, end = endpoints(scene.surface)
        x = np.asarray(scene.x)
        kd_ms = None
        for name, baseline in (
            ("cKDTree + NumPy projection", kdtree_project),
            ("cKDTree pairs + NumPy projection", kdtree_pairs_project),
        ):
            kd = baseline(x, start, end, radius)
            kd_timing = time_call(baseline, x, start, end, radius, repeats=max(3, repeats // 5))
            check = mismatches(kd, reference) if reference is not None else "no dense reference"
            report(section, name, num_nodes, num_segments, kd_timing, None, check)
            # Ratios are against the faster of the two.
            kd_ms = min(kd_ms or np.inf, kd_timing.median_s * 1e3)
        for cell_factor in (0.5, 1.0, 2.0):
            sizes = measure(scene.x, scene.surface, radius=radius, cell_factor=cell_factor)
            detect = sized_contact(radius, sizes)
            compiled = detect.lower(scene.x, scene.surface).compile()
            memory = compiled.memory_analysis()
            peak = memory.temp_size_in_bytes + memory.output_size_in_bytes
            timing, result = time_bucket(scene, radius, sizes, repeats)
            if reference is None:
                check = differ_from_kdtree(x, start, end, np.asarray(result.segment), kd[0])
            else:
                check = mismatches((result.segment, result.found), reference)
            check += f"; overflow={bool(result.overflow)}; XLA temp+out {peak / 2**20:.0f} MiB"
            cells = f"{sizes.grid_shape[0]}x{sizes.grid_shape[1]}"
            check += f"; {cells} cells, capacity {sizes.cell_capacity}"
            report(
                section,
                f"bucket_sort (sized) cells x{cell_factor}",
                num_nodes,
                num_segments,
                timing,
                timing.compile_s,
                check,
                kd_ms,
            )
        if reference is not None:
            dense = jax.jit(functools.partial(all_to_all, radius=radius))
            timing = time_call(dense, scene.x, scene.surface, repeats=max(3, repeats // 5))
            report(
                section,
                "all_to_all",
                num_nodes,
                num_segments,
                timing,
                timing.compile_s,
                "reference (float32)",
                kd_ms,
            )


def paper_section(n, repeats):
    for test, length, travel in (("Test 1", 10.0, 5.0), ("Test 2", 20.0, 10.0)):
        scene = paper_scene(n, length=length, d=travel)
        nodes = scene.x.shape[0]
        section = f"paper {test} d={travel}"
        radius = scene.radius
        dense = jax.jit(functools.partial(all_to_all, radius=radius))
        timing = time_call(dense, scene.x, scene.surface, repeats=repeats)
        dense_ms = timing.median_s * 1e3
        report(section, "all_to_all", nodes, 2, timing, timing.compile_s, "")
        sizes = measure(scene.x, scene.surface, radius=radius)
        timing, result = time_bucket(scene, radius, sizes, repeats)
        reference = dense(scene.x, scene.surface)
        check = mismatches((result.segment, result.found), reference)
        method = "bucket_sort (sized)"
        report(section, method, nodes, 2, timing, timing.compile_s, check, dense_ms)
        crossing = jax.jit(swept)
        timing = time_call(crossing, scene.x_prev, scene.x, scene.surface, repeats=repeats)
        swept_ms = timing.median_s * 1e3
        reference = crossing(scene.x_prev, scene.x, scene.surface)
        crossed = f"{int(reference.crossed.sum())} crossed"
        report(section, "swept", nodes, 2, timing, timing.compile_s, crossed)
        binned = sized_crossing(measure(scene.x, scene.surface, x_prev=scene.x_prev))
        timing = time_call(binned, scene.x_prev, scene.x, scene.surface, repeats=repeats)
        result = binned(scene.x_prev, scene.x, scene.surface)
        wrong = int((np.asarray(result.segment) != np.asarray(reference.segment)).sum())
        check = f"{wrong} rows differ"
        method = "bucket_swept (sized)"
        report(section, method, nodes, 2, timing, timing.compile_s, check, swept_ms)


def reuse_section(num_nodes, repeats):
    scene = cutting_scene(num_nodes, 18.0)
    radius, skin = scene.radius, scene.radius / 2
    section = "cutting x_tip=18, reuse"
    reference = reference_contact(scene, radius)
    # Sized at radius + skin, as the candidates are; the fresh search (its
    # broad phase at the radius) runs with the same sizes.
    sizes = measure(scene.x, scene.surface, radius=radius + skin)
    fresh, result = time_bucket(scene, radius, sizes, repeats)
    check = mismatches((result.segment, result.found), reference)
    method = "bucket_sort (sized at radius + skin), fresh search"
    report(section, method, num_nodes, 20, fresh, fresh.compile_s, check)
    reach = jnp.asarray(radius + skin, scene.x.dtype)
    near = _bucket.find_jit(scene.x, scene.surface, reach, None, sizes=sizes)

    @jax.jit
    def reused(x, surface, candidates):
        r = jnp.asarray(radius, x.dtype)
        return _bucket.contact_jit(x, surface, r, None, sizes=sizes, candidates=candidates)

    timing = time_call(reused, scene.x, scene.surface, near, repeats=repeats)
    result = reused(scene.x, scene.surface, near)
    check = mismatches((result.segment, result.found), reference)
    method = "bucket_sort (sized), reused candidates"
    report(section, method, num_nodes, 20, timing, timing.compile_s, check, fresh.median_s * 1e3)
    # The public form: the skin rule checked, the candidates kept (no re-find).
    search = Search(radius=radius, skin=skin)
    state = search.allocate(scene.x, scene.surface)
    step = jax.jit(search.closest)
    timing = time_call(step, state, scene.x, scene.surface, repeats=repeats)
    result, after = step(state, scene.x, scene.surface)
    check = mismatches((result.segment, result.found), reference)
    check += f"; rebuilds {int(after.rebuilds)}"
    method = "Search.closest (reused state)"
    report(section, method, num_nodes, 20, timing, timing.compile_s, check, fresh.median_s * 1e3)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small sizes, a smoke test")
    parser.add_argument("--repeats", type=int, default=30)
    parser.add_argument("--sections", default="cutting,die,paper,reuse")
    parser.add_argument("--die-sizes", default="1e5:1e4,1e6:1e5", help="N:M pairs, comma separated")
    args = parser.parse_args()
    jax.config.update("jax_enable_x64", True)
    print(f"# bucket.py: jax {jax.__version__}, {pinned_note()}")
    print(
        "section | method | nodes | segments | median ms | p10-p90 ms | speed-up"
        " | compile s | check"
    )
    print("---|---|---|---|---|---|---|---|---")
    sections = args.sections.split(",")
    if "cutting" in sections:
        cutting_section(2_000 if args.quick else 81_939, args.repeats, args.quick)
    if "die" in sections:
        pairs = [pair.split(":") for pair in args.die_sizes.split(",")]
        sizes = (
            [(10**4, 10**3)] if args.quick else [(int(float(n)), int(float(m))) for n, m in pairs]
        )
        rough_die_section(sizes, args.repeats)
    if "paper" in sections:
        paper_section(30 if args.quick else 286, args.repeats)
    if "reuse" in sections:
        reuse_section(2_000 if args.quick else 81_939, args.repeats)
    print(
        "\nspeed-up: the baseline's median over this row's median (cutting and paper:"
        " all_to_all or swept; rough die: the faster cKDTree baseline)."
    )


if __name__ == "__main__":
    main()
