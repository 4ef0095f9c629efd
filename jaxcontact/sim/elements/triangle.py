"""Linear triangles, plane strain, small strain, linear elastic (``materials.Elastic``).

The element of the ploughing run and of ``hertz``'s static solve, any mesh
built by ``triangle_mesh``, lumped masses. Everything an
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

from typing import NamedTuple

import jax.numpy as jnp
import numpy as np
from jax import Array

from jaxcontact.sim.materials import Elastic, inertial_density
from jaxcontact.sim.materials import von_mises as _von_mises

__all__ = [
    "Mesh",
    "internal_forces",
    "smallest_altitude",
    "strain_energy",
    "stresses",
    "triangle_mesh",
    "von_mises",
]


class Mesh(NamedTuple):
    """A triangle mesh with what its elements need precomputed. E elements, N nodes."""

    nodes: Array  # f[N, 2]  reference coordinates (mm)
    triangles: Array  # i32[E, 3]  counter-clockwise node indices
    gradients: Array  # f[E, 3, 2]  d(shape function a)/dx of each element's node a
    area: Array  # f[E]  element areas (mm²)
    mass: Array  # f[N]  lumped nodal masses (t per mm of thickness)
    free: Array  # bool[N]  False on the fixed bottom edge
    boundary: Array  # i32[B]  the free edges' nodes in order: left up, top across, right down


def triangle_mesh(
    nodes: np.ndarray,
    triangles: np.ndarray,
    free: np.ndarray,
    boundary: np.ndarray,
    material: Elastic,
    *,
    dtype=jnp.float32,
) -> Mesh:
    """A ``Mesh`` of any linear triangles, with what its elements need computed on the host.

    Args:
      nodes: f[N, 2] reference coordinates (mm).
      triangles: int[E, 3] node indices, counter-clockwise (positive areas).
      free: bool[N], False on fixed nodes.
      boundary: int[B] the free outline's nodes in order along it.
      material: gives the lumped masses (a third of each element's to each node),
        mass scaling included.
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
    np.add.at(mass, triangles, (inertial_density(material) * area / 3)[:, None])
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


def stresses(mesh: Mesh, displacement: Array, material: Elastic) -> Array:
    """f[E, 2, 2]: the in-plane Cauchy stress of every element (MPa).

    Plane strain: ``σ = λ tr(ε) I + 2 μ ε`` with ``ε`` the symmetric part of the
    displacement gradient ``Σ_a u_a ⊗ grad N_a``.
    """
    lam, mu = material.lame
    gradient = jnp.einsum("eai,eaj->eij", displacement[mesh.triangles], mesh.gradients)
    strain = (gradient + jnp.swapaxes(gradient, 1, 2)) / 2
    trace = strain[:, 0, 0] + strain[:, 1, 1]
    return lam * trace[:, None, None] * jnp.eye(2, dtype=strain.dtype)[None] + 2 * mu * strain


def internal_forces(mesh: Mesh, displacement: Array, material: Elastic) -> Array:
    """f[N, 2]: the elastic force on every node, ``-K u`` (N per mm of thickness)."""
    sigma = stresses(mesh, displacement, material)
    per_node = -mesh.area[:, None, None] * jnp.einsum("eij,eaj->eai", sigma, mesh.gradients)
    return jnp.zeros_like(displacement).at[mesh.triangles].add(per_node)


def strain_energy(mesh: Mesh, displacement: Array, material: Elastic) -> Array:
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


def von_mises(sigma: Array, material: Elastic) -> Array:
    """f[E]: the von Mises stress of plane-strain stresses, with ``σ_zz = ν (σ_xx + σ_yy)``."""
    sxx, syy, sxy = sigma[:, 0, 0], sigma[:, 1, 1], sigma[:, 0, 1]
    szz = material.poisson * (sxx + syy)
    return _von_mises(jnp.stack([sxx, syy, szz, sxy], axis=-1))
