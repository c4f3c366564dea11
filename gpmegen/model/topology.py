"""The tree of a flattened model: which joint each joint hangs from, which joints move each body
and point.

Joints are numbered in chain order (the order of ``q``), and a joint's parent always comes
before it (the chain lists its elements in topological order), so ``parent[j] < j``. Joint ``-1``
stands for the ground. A serial chain is the case ``parent[j] = j - 1``; a
:class:`~gpmegen.model.chain.Branch` element starts a new branch from a point of the chain built so
far, so several joints may share a parent.

- ``supports[j]``: the joints that move joint ``j``'s frame: its ancestors and itself, ascending;
- ``subtree[j]``: the joints that joint ``j`` moves: itself and its descendants, ascending;
- ``children[j]``: the joints whose parent is ``j``, ascending.

Joint ``i`` moves what joint ``j`` moves when ``i`` supports ``j``; the mass matrix entry
``M_ij`` can differ from zero only when one of the two supports the other (:meth:`related`).
"""

from __future__ import annotations

from dataclasses import dataclass

GROUND = -1


@dataclass(frozen=True)
class Topology:
    """``parent`` (n,): each joint's parent joint (``-1``: the ground); ``body_joint`` (one per
    body, in chain order) and ``point_joint`` (one per point): the joint that moves it (``-1``:
    fixed to the ground). ``supports``, ``subtree``, ``children`` (n tuples each) follow from
    ``parent`` (:meth:`of`)."""

    parent: tuple
    body_joint: tuple
    point_joint: tuple
    supports: tuple
    subtree: tuple
    children: tuple

    @classmethod
    def of(cls, parent, body_joint=(), point_joint=()) -> Topology:
        """The topology of joints with parents ``parent`` (each ``-1`` or an earlier joint's
        index); ValueError otherwise."""
        parent = tuple(int(p) for p in parent)
        n = len(parent)
        for j, p in enumerate(parent):
            if not GROUND <= p < j:
                raise ValueError(f"joint {j}: parent {p} is neither the ground (-1) nor an earlier joint")
        for j in (*body_joint, *point_joint):
            if not GROUND <= j < n:
                raise ValueError(f"a body or point is moved by joint {j}, which does not exist")
        supports: list[tuple] = []
        for j, p in enumerate(parent):
            supports.append((supports[p] if p != GROUND else ()) + (j,))
        children = [[] for _ in range(n)]
        subtree = [[j] for j in range(n)]
        for j, p in enumerate(parent):
            if p != GROUND:
                children[p].append(j)
        for j in reversed(range(n)):
            for k in supports[j][:-1]:
                subtree[k].append(j)
        return cls(parent, tuple(body_joint), tuple(point_joint), tuple(supports),
                   tuple(tuple(sorted(s)) for s in subtree), tuple(tuple(c) for c in children))

    @classmethod
    def serial(cls, n: int) -> Topology:
        """The chain of ``n`` joints each moved by the one before it."""
        return cls.of(tuple(range(-1, n - 1)))

    @property
    def n_dof(self) -> int:
        return len(self.parent)

    @property
    def is_serial(self) -> bool:
        """Whether every joint hangs from the one before it."""
        return all(p == j - 1 for j, p in enumerate(self.parent))

    def related(self, i: int, j: int) -> bool:
        """Whether one of joints ``i``, ``j`` supports the other (``M_ij`` may be non-zero)."""
        return i in self.supports[j] or j in self.supports[i]

    def moved_by(self, joint: int) -> tuple:
        """The joints that move what ``joint`` moves (its supports; ``()`` for the ground)."""
        return () if joint == GROUND else self.supports[joint]
