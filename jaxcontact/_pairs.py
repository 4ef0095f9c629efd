"""The pair rule, a public type: which slave may meet which segment.

``jaxcontact._pipeline.pairs`` applies it to every search's kernels. The rule,
for slave ``i`` and a real segment ``k``:

1. **Own node.** With ``slave_node`` given, ``i`` never meets a segment that
   has its own node as an end (it lies on it, at distance 0).
2. **Bodies.** With ``slave_body`` and ``surface.body`` both given, ``i``
   meets only other bodies' segments.
3. **Self-contact** (``self_contact=True``, which replaces rule 2): ``i``
   meets its own body's segments too, except those within its
   neighbourhood along the outline: the segments whose arc-length distance
   from ``i``'s node, along the chain of segments through it
   (``_pipeline.outline``), is below ``SELF_CONTACT_REACH`` times its reach (the
   radius for closest points, the path's length for crossings).

Why arc length, and why that window (the repository's docs/contract.md has more):
near a corner of its own outline a slave lies within the radius of the
faces beyond the corner, and behind them at a convex corner, so a plain
search reports a false penetration there. A segment on the other face of a
corner of interior angle ``theta``, at arc length ``s`` from the slave, is
at least ``s sin(theta / 2)`` from it (the chord of a wedge), so excluding
arc lengths below ``4 r`` leaves no pair within the radius ``r`` at any
corner sharper than 180 degrees down to ``2 asin(1/4) = 29`` degrees. A
fold pressed onto the slave comes from far along the outline and is kept.
LS-DYNA's single-surface contact and Radioss's type 7 exclude the
neighbouring segments by topology, as here; normals that oppose (the other
usual test) do not separate a sharp convex corner from a fold, whose faces
oppose too. What no local rule can tell apart is a part of the body
thinner than the radius: a slave there lies within the radius behind its
own body's opposite face, exactly as if it penetrated it. Keep the radius
below the thinnest part's thickness.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable

import jax

from jaxcontact._types import Array

# The self-contact neighbourhood, in multiples of a slave's reach (above).
SELF_CONTACT_REACH = 4.0


@dataclasses.dataclass(frozen=True)
class Rule:
    """Which parts of the rule apply: static, decided by which inputs were given."""

    own_node: bool
    bodies: bool
    self_contact: bool
    allow: object = None  # the user's own rule (``Pairs.allow``), or None


@functools.partial(
    jax.tree_util.register_dataclass,
    data_fields=["slave_node", "slave_body"],
    meta_fields=["self_contact", "allow"],
)
@dataclasses.dataclass(frozen=True)
class Pairs:
    """The pair rule: which slave may meet which segment (the rule above).

    One value, passed as ``pairs=`` to every detector and to ``Search``'s
    methods. The default, ``Pairs()``, lets every slave meet every real
    segment. A pytree: ``slave_node`` and ``slave_body`` are traced arrays
    (padded, batched and sharded with the slaves), ``self_contact`` is
    static.

    Attributes:
      slave_node: i32[N] or None: the index in ``surface.nodes`` that each
        slave is (-1 for none). A slave never meets a segment that has its
        own node as an end.
      slave_body: i32[N] or None: each slave's body. With ``surface.body``
        too, a slave meets only other bodies' segments.
      self_contact: a slave also meets its own body's segments, except
        those within its neighbourhood along the outline
        (``SELF_CONTACT_REACH`` times its reach: the radius, or a path's
        length). Needs ``slave_node``; with no body labels the whole surface
        is one body.
      allow: a rule of the user's own, the hook jax-md's neighbour lists
        call ``custom_mask_function``: ``allow(slave, segment) -> bool``,
        elementwise over i32 arrays of slave rows and segment indices of
        matching shape (write it with ``jnp``; it is traced). A pair meets
        only if ``allow`` and the rule above both let it. Static: hashed by
        identity, so pass the same function each step (a new one compiles
        anew). It may also be called on padding (rows past N, segments
        past M, empty slots); those answers are masked out.

    Example:
      >>> import jax.numpy as jnp
      >>> from jaxcontact import Pairs, Surface, all_to_all
      >>> square = Surface(
      ...     jnp.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]),
      ...     jnp.array([[0, 1], [1, 2], [2, 3], [3, 0]]),
      ... )
      >>> own = Pairs(slave_node=jnp.array([0, 1, 2, 3]))  # each corner is a slave
      >>> contact = all_to_all(square.nodes, square, radius=1.5, pairs=own)
      >>> contact.segment.tolist()  # the nearest segment not through its own corner
      [1, 2, 0, 0]
    """

    slave_node: Array | None = None  # i32[N]  surface node of each slave, -1 for none
    slave_body: Array | None = None  # i32[N]  body of each slave
    self_contact: bool = False
    allow: Callable[[Array, Array], Array] | None = None

    def rule(self, body) -> Rule | None:
        """The ``Rule`` for a surface with labels ``body`` (or None): None if nothing applies."""
        rule = Rule(
            own_node=self.slave_node is not None,
            bodies=self.slave_body is not None and body is not None,
            self_contact=self.self_contact,
            allow=self.allow,
        )
        applies = rule.own_node or rule.bodies or rule.self_contact or rule.allow is not None
        return rule if applies else None
