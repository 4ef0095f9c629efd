"""Linear triangles, plane strain, linear elastic: the workpiece of ``simulate``.

Not a general finite-element code: two meshes (the cutting scene's grid,
each cell cut into two triangles, and ``hertz``'s graded block, both built
by ``triangle_mesh``), one material law, lumped masses. Everything an
element needs that does not change over a run (shape-function gradients,
areas, masses) is computed once on the host; a step gathers the element's
node displacements, computes its stresses and scatters its nodal forces with
``.at[].add``; a static solve minimises ``strain_energy`` instead. Small
strain: the model is linear in the displacement, so it is right for the
small deformations near the tool and wrong (not objective) for large
rotations.

Units: mm, N, tonne, s (so stresses in MPa and densities in t/mm³). Plane
strain per 1 mm of thickness: forces are N per mm of width.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import jax.numpy as jnp
import numpy as np
from jax import Array

from jaxcontact.scenes import grid


class Material(NamedTuple):
    """A linear elastic, isotropic material; steel by default.

    ``mass_scale`` multiplies the density, as explicit codes do to make the
    stable time step longer (mass scaling): with it the waves are slower by
    its square root and the run needs that many times fewer steps.
    """

    young: float = 210_000.0  # MPa
    poisson: float = 0.3
    density: float = 7.85e-9  # t/mm³
    mass_scale: float = 1.0

    @property
    def lame(self) -> tuple[float, float]:
        """(λ, μ) in MPa."""
        nu = self.poisson
        return self.young * nu / ((1 + nu) * (1 - 2 * nu)), self.young / (2 * (1 + nu))

    @property
    def wave_speed(self) -> float:
        """The dilatational wave speed sqrt((λ + 2μ) / ρ) in mm/s, with mass scaling."""
        lam, mu = self.lame
        return math.sqrt((lam + 2 * mu) / (self.density * self.mass_scale))


class Mesh(NamedTuple):
    """A triangle mesh with what its elements need precomputed. E elements, N nodes."""

    nodes: Array  # f[N, 2]  reference coordinates (mm)
    triangles: Array  # i32[E, 3]  counter-clockwise node indices
    gradients: Array  # f[E, 3, 2]  d(shape function a)/dx of each element's node a
    area: Array  # f[E]  element areas (mm²)
    mass: Array  # f[N]  lumped nodal masses (t per mm of thickness)
    free: Array  # bool[N]  False on the fixed bottom edge
    boundary: Array  # i32[B]  the free edges' nodes in order: left up, top across, right down


def workpiece_mesh(num_nodes: int, material: Material, *, dtype=jnp.float32) -> Mesh:
    """The cutting scene's workpiece grid split into linear triangles.

    The grid is ``scenes.cutting_scene``'s (``[0, 20] x [0, 5]``, ``nx / ny ~ 4``,
    numbered row by row), so the slaves of a simulation are that scene's
    slaves. Each grid cell becomes two counter-clockwise triangles; each
    triangle gives a third of its mass to each of its nodes. Nodes on
    ``y = 0`` are fixed; ``boundary`` lists the others on the outline, in
    order along it, so that consecutive rows are close in space (as
    ``bucket_sort``'s culling in blocks of rows wants).

    Example:
      >>> mesh = workpiece_mesh(2_000, Material())
      >>> mesh.nodes.shape, mesh.triangles.shape
      ((2002, 2), (3780, 3))
    """
    ny = max(2, round(math.sqrt(num_nodes / 4)))
    nx = max(2, round(num_nodes / ny))
    nodes = grid((0.0, 20.0), (0.0, 5.0), nx, ny)
    corner = (np.arange(ny - 1)[:, None] * nx + np.arange(nx - 1)[None, :]).ravel()
    lower = np.stack([corner, corner + 1, corner + nx + 1], axis=-1)
    upper = np.stack([corner, corner + nx + 1, corner + nx], axis=-1)
    triangles = np.concatenate([lower, upper]).astype(np.int32)

    rows = np.arange(ny)[:, None] * nx + np.arange(nx)[None, :]
    boundary = np.concatenate([rows[1:, 0], rows[-1, 1:], rows[-2:0:-1, -1]])
    return triangle_mesh(nodes, triangles, nodes[:, 1] > 0, boundary, material, dtype=dtype)


def triangle_mesh(
    nodes: np.ndarray,
    triangles: np.ndarray,
    free: np.ndarray,
    boundary: np.ndarray,
    material: Material,
    *,
    dtype=jnp.float32,
) -> Mesh:
    """A ``Mesh`` of any linear triangles, with what its elements need computed on the host.

    Args:
      nodes: f[N, 2] reference coordinates (mm).
      triangles: int[E, 3] node indices, counter-clockwise (positive areas).
      free: bool[N], False on fixed nodes.
      boundary: int[B] the free outline's nodes in order along it.
      material: gives the lumped masses (a third of each element's to each node).
      dtype: the float dtype of the arrays.
    """
    nodes, triangles = np.asarray(nodes, np.float64), np.asarray(triangles, np.int32)
    corners = nodes[triangles]  # (E, 3, 2)
    edge_1, edge_2 = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
    twice_area = edge_1[:, 0] * edge_2[:, 1] - edge_1[:, 1] * edge_2[:, 0]
    if not (twice_area > 0).all():
        raise ValueError(
            "triangles must be counter-clockwise (positive areas); got "
            f"{int((twice_area <= 0).sum())} of {len(triangles)} that are not"
        )
    # Linear shape functions: grad N_a = (y_b - y_c, x_c - x_b) / 2A over the
    # cyclic triples (a, b, c).
    following, opposite = corners[:, [1, 2, 0]], corners[:, [2, 0, 1]]
    gradients = (
        np.stack(
            [following[..., 1] - opposite[..., 1], opposite[..., 0] - following[..., 0]], axis=-1
        )
        / twice_area[:, None, None]
    )
    area = twice_area / 2
    mass = np.zeros(len(nodes))
    np.add.at(mass, triangles, (material.density * material.mass_scale * area / 3)[:, None])
    return Mesh(
        jnp.asarray(nodes, dtype),
        jnp.asarray(triangles),
        jnp.asarray(gradients, dtype),
        jnp.asarray(area, dtype),
        jnp.asarray(mass, dtype),
        jnp.asarray(free, bool),
        jnp.asarray(boundary, np.int32),
    )


def smallest_altitude(mesh: Mesh) -> float:
    """The smallest element altitude 2A / (longest edge), the CFL length (host)."""
    corners = np.asarray(mesh.nodes, np.float64)[np.asarray(mesh.triangles)]
    edges = np.linalg.norm(corners - corners[:, [1, 2, 0]], axis=-1).max(axis=-1)
    return float((2 * np.asarray(mesh.area, np.float64) / edges).min())


def stresses(mesh: Mesh, displacement: Array, material: Material) -> Array:
    """f[E, 2, 2]: the in-plane Cauchy stress of every element (MPa).

    Plane strain: ``σ = λ tr(ε) I + 2 μ ε`` with ``ε`` the symmetric part of the
    displacement gradient ``Σ_a u_a ⊗ grad N_a``.
    """
    lam, mu = material.lame
    gradient = jnp.einsum("eai,eaj->eij", displacement[mesh.triangles], mesh.gradients)
    strain = (gradient + jnp.swapaxes(gradient, 1, 2)) / 2
    trace = strain[:, 0, 0] + strain[:, 1, 1]
    return lam * trace[:, None, None] * jnp.eye(2, dtype=strain.dtype)[None] + 2 * mu * strain


def internal_forces(mesh: Mesh, displacement: Array, material: Material) -> Array:
    """f[N, 2]: the elastic force on every node, ``-K u`` (N per mm of thickness)."""
    sigma = stresses(mesh, displacement, material)
    per_node = -mesh.area[:, None, None] * jnp.einsum("eij,eaj->eai", sigma, mesh.gradients)
    return jnp.zeros_like(displacement).at[mesh.triangles].add(per_node)


def strain_energy(mesh: Mesh, displacement: Array, material: Material) -> Array:
    """f[]: the elastic strain energy ``Σ_e A_e (μ ε:ε + λ/2 tr(ε)²)`` (N mm per mm of thickness).

    Its gradient with respect to ``displacement`` is ``-internal_forces``; the
    material's moduli may be traced (``jax.grad`` with respect to E or ν).
    """
    lam, mu = material.lame
    gradient = jnp.einsum("eai,eaj->eij", displacement[mesh.triangles], mesh.gradients)
    strain = (gradient + jnp.swapaxes(gradient, 1, 2)) / 2
    trace = strain[:, 0, 0] + strain[:, 1, 1]
    density = mu * jnp.sum(strain**2, axis=(1, 2)) + lam / 2 * trace**2
    return jnp.sum(mesh.area * density)


def von_mises(sigma: Array, material: Material) -> Array:
    """f[E]: the von Mises stress of plane-strain stresses, with ``σ_zz = ν (σ_xx + σ_yy)``."""
    sxx, syy, sxy = sigma[:, 0, 0], sigma[:, 1, 1], sigma[:, 0, 1]
    szz = material.poisson * (sxx + syy)
    return jnp.sqrt(((sxx - syy) ** 2 + (syy - szz) ** 2 + (szz - sxx) ** 2) / 2 + 3 * sxy**2)
