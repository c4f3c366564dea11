"""Splitting a long straight-line function into blocks of bounded length (the C backend).

A generated function is one basic block of straight-line code, and a C compiler's optimization
time and memory grow faster than linearly with the length of one basic block (scheduling and
register allocation over hundreds of live values): one ``gpme_terms`` of 9,000 statements took
most of a compile that grew as n_dof^1.76. A function longer than :data:`SPLIT_ABOVE` is split
into blocks of at most :data:`MAX_STATEMENTS` statements, each a function of its own that the
compiler optimizes apart, and the compile grows about linearly. A value a later block reads
passes through a workspace array ``w`` that the exported function holds on its stack; every value
is computed by the same expression as in one block and a double goes through memory unchanged,
so the arithmetic, and every result, is the same.
"""

from __future__ import annotations

from dataclasses import dataclass

#: Statements (definitions and output stores) of one block. The hot part of model.c at
#: n_rfe = 20 (gcc 12, -O3) took 6.8 s of CPU in blocks of 400 and 5.6 s in blocks of 200, against
#: 63 s whole; smaller blocks load more values from w (a longer file).
MAX_STATEMENTS = 300
#: A function of at most this many statements stays one block: it compiles fast enough, and cut
#: into blocks, gpme_terms of n_rfe = 5 (1,194 statements) made a GPME right-hand side 37% slower
#: (1.2 -> 1.65 µs), while at n_rfe = 10 (3,044) the blocks cost 2% and at 20 nothing.
SPLIT_ABOVE = 2000

@dataclass(frozen=True)
class Block:
    """One block of a function: the inputs it reads, the earlier blocks' values it loads from
    the workspace, its definitions, the values it stores for later blocks, its output stores."""

    time_used: bool
    q_used: tuple     # (index, local name)
    qd_used: tuple
    p_used: tuple
    loads: tuple      # (workspace slot, local name)
    body: tuple       # (local name, code)
    stores: tuple     # (workspace slot, local name)
    outputs: tuple    # (output name, index, code)
    outputs_written: tuple  # names of the outputs this block writes
    a_used: tuple = ()  # given accelerations and multipliers read (functions with inputs a, lam)
    lam_used: tuple = ()


def split(definitions, outputs, uses, time_symbol, inputs, limit=None):
    """Blocks of the straight-line code of one function, or ``((), 0)`` when it has at most
    :data:`SPLIT_ABOVE` statements.

    ``definitions``: ``(symbol, local name, code)`` in order; ``outputs``: ``(output name,
    index, code)`` in order; ``uses``: for each definition and then each output, the set of
    symbols its expression reads; ``inputs``: ``{"q": ((symbol, index, local name), ...), "qd":
    ..., "p": ...}`` and, for functions that take them, ``"a"``, ``"lam"``; ``limit``:
    statements per block (default :data:`MAX_STATEMENTS`).
    Returns ``(blocks, workspace size)``."""
    limit = limit or MAX_STATEMENTS
    statements = list(definitions) + list(outputs)
    if len(statements) <= max(limit, SPLIT_ABOVE):
        return (), 0
    ranges = [range(k, min(k + limit, len(statements))) for k in range(0, len(statements), limit)]
    block_of = {definitions[i][0]: i // limit for i in range(len(definitions))}
    crossing = set()
    for i, used in enumerate(uses):
        crossing.update(s for s in used if s in block_of and block_of[s] != i // limit)
    slot = {}
    for symbol, _, _ in definitions:  # slots in order of definition
        if symbol in crossing:
            slot[symbol] = len(slot)
    local = {symbol: name for symbol, name, _ in definitions}
    blocks = []
    for k, indices in enumerate(ranges):
        read = set().union(*(uses[i] for i in indices))
        defined = [definitions[i] for i in indices if i < len(definitions)]
        written = [statements[i] for i in indices if i >= len(definitions)]
        loads = tuple(sorted((slot[s], local[s]) for s in read if s in slot and block_of[s] < k))
        # a value read in another block is read in a later one: definitions come before their uses
        stores = tuple((slot[s], name) for s, name, _ in defined if s in slot)
        blocks.append(Block(
            time_symbol in read,
            *(tuple((j, name) for s, j, name in inputs[kind] if s in read) for kind in ("q", "qd", "p")),
            loads, tuple((name, code) for _, name, code in defined), stores, tuple(written),
            tuple(dict.fromkeys(name for name, _, _ in written)),
            *(tuple((j, name) for s, j, name in inputs.get(kind, ()) if s in read) for kind in ("a", "lam")),
        ))
    return tuple(blocks), len(slot)
