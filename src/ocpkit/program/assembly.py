"""The blocks of a program's NLP beyond its schemes': everything that is the same on every scheme.

Per phase (:func:`phase_blocks`): the scheme's own blocks (defects and running cost, rules 4-5 of
:class:`~ocpkit.program.scheme.Scheme`), then the Mayer term ``phi(x(t0), x(tf), t0, tf) / objective_scale``
on the phase's boundary values, the path constraints ``g / scale`` at the scheme's points, the boundary constraints
``psi / scale``, and each control end value that no point holds, ``sum_k w_k U_k`` (scaled). Across phases
(:func:`link_blocks`, :func:`trajectory_blocks`): each link's ``(x_after(t0) - x_before(tf) - jump) / scale`` rows
and its time row ``(t0_after - tf_before) / scale``, the trajectory's cost and its linkage constraints on every
phase's boundary values. A phase's blocks are written in its own numbering and mapped to the NLP's
(:func:`globalised`); each stays the small mapped function it was, so the NLP keeps its block-separable exact
derivatives.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import casadi as ca
import numpy as np

from ..nlp import Block
from ..statement.phases import MultiPhaseProblem
from .layout import Phase, PhaseLayout


def globalised(block: Block, phase: Phase, prefix: str) -> Block:
    """``block`` (in the phase's numbering, its rows the phase's) in the NLP's numbering and rows, named with
    ``prefix``."""
    rows = None if block.rows is None else block.rows + phase.row_offset
    return replace(block, name=prefix + block.name, variables=phase.to_global[block.variables], rows=rows)


def mayer_block(layout: PhaseLayout) -> Block:
    """The Mayer term ``phi(x(t0), x(tf), t0, tf) / objective_scale`` of a phase (its own numbering)."""
    pr = layout.problem
    z, q, x0, xf, t0, tf, P = layout.boundary_symbols()
    phi = pr.mayer(x0, xf, t0, tf, P)
    var = layout.boundary_variables()
    par = np.array(layout.constants, dtype=float).reshape(-1, 1)
    return Block("mayer", ca.Function("mayer", [z, q], [phi / layout.objective_scale]), var[:, None], par)


def constraint_blocks(phase: Phase) -> list[Block]:
    """The path constraints ``g / scale`` at every one of the scheme's path points, the boundary constraints
    ``psi / scale`` and the control end values no point holds, in rows after the defects (the phase's numbering)."""
    layout, pr = phase.layout, phase.problem
    blocks: list[Block] = []
    row = phase.n_defects
    path = pr.functions.path
    if path is not None:
        scale = ca.DM(path.scale)
        for j, pp in enumerate(phase.path_points):
            P = layout.times.P(pp.z)
            out = ca.vertcat(*[pr.path(x, u, t, P) / scale for x, u, t in zip(pp.x, pp.u, pp.t)])
            per = out.shape[0]
            rows = row + np.arange(per * pp.count).reshape(pp.count, per).T
            fun = ca.Function(f"path_{j}", [pp.z, pp.p], [out])
            blocks.append(Block(f"path_constraints_{j}", fun, pp.variables, pp.constants, rows))
            row += per * pp.count
    boundary = pr.functions.boundary
    if boundary is not None:
        z, q, x0, xf, t0, tf, P = layout.boundary_symbols()
        out = pr.boundary(x0, xf, t0, tf, P) / ca.DM(boundary.scale)
        var = layout.boundary_variables()
        par = np.array(layout.constants, dtype=float).reshape(-1, 1)
        rows = row + np.arange(boundary.size)[:, None]
        blocks.append(Block("boundary_constraints", ca.Function("boundary", [z, q], [out]), var[:, None], par, rows))
        row += boundary.size
    for end in phase.control_ends:
        m = end.variables.size
        z = ca.SX.sym("z", m)
        fun = ca.Function("control_end", [z, ca.SX.sym("q", 0)], [ca.dot(ca.DM(end.weights), z)])
        name = f"control_{end.which}_{end.control.name}"
        blocks.append(Block(name, fun, end.variables[:, None], np.zeros((0, 1)), np.array([[row]]), end.weights[None]))
        row += 1
    return blocks


def phase_blocks(phase: Phase, prefix: str) -> list[Block]:
    """Every block of one phase, in the NLP's numbering: the scheme's, the Mayer term, the constraints (module
    docstring)."""
    layout = phase.layout
    local = list(phase.scheme.blocks(layout))
    if phase.problem.functions.phi is not None:
        local.append(mayer_block(layout))
    local += constraint_blocks(phase)
    return [globalised(b, phase, prefix) for b in local]


def link_blocks(
    statement: MultiPhaseProblem, phases: Sequence[Phase], link_rows: Sequence[tuple[int, int]]
) -> list[Block]:
    """Each link's state rows, then its time row where the times meet by a constraint (module docstring)."""
    blocks: list[Block] = []
    for linked, (row, _) in zip(statement.links, link_rows):
        pb, pa = phases[linked.before], phases[linked.after]
        if linked.states:
            _, end_b = pb.layout.boundary_states
            start_a, _ = pa.layout.boundary_states
            ib = np.array([i for i, _, _, _ in linked.states])
            ia = np.array([j for _, j, _, _ in linked.states])
            sb, sa = pb.problem.state_scaling.subset(ib), pa.problem.state_scaling.subset(ia)
            m = len(linked.states)
            z = ca.SX.sym("z", 2 * m)
            q = ca.SX.sym("q", m)  # the jumps
            out = (sa.from_nlp(z[m:]) - sb.from_nlp(z[:m]) - q) / ca.DM(sa.scale)
            var = np.concatenate([pb.to_global[end_b[ib]], pa.to_global[start_a[ia]]])[:, None]
            jumps = np.array([[jump] for _, _, _, jump in linked.states])
            rows = row + np.arange(m)[:, None]
            name = f"link_{linked.before}_{linked.after}"
            blocks.append(Block(name, ca.Function("link", [z, q], [out]), var, jumps, rows))
            row += m
        if linked.time == "constraint":
            # t0_after - tf_before = 0 on the two phases' boundary symbols (each time however its phase holds it)
            zb, qb, _, _, _, tf_before, _ = pb.layout.boundary_symbols()
            za, qa, _, _, t0_after, _, _ = pa.layout.boundary_symbols()
            var = np.concatenate([p.to_global[p.layout.boundary_variables()] for p in (pb, pa)]).astype(np.int64)
            par = np.array([*pb.layout.constants, *pa.layout.constants], dtype=float)
            scale = max(abs(float(pb.problem.tf_guess)), 1.0)
            fun = ca.Function("link_time", [ca.vertcat(zb, za), ca.vertcat(qb, qa)], [(t0_after - tf_before) / scale])
            name = f"link_time_{linked.before}_{linked.after}"
            blocks.append(Block(name, fun, var[:, None], par[:, None], np.array([[row]])))
    return blocks


def ends_function(phases: Sequence[Phase]) -> tuple[ca.SX, ca.SX, ca.SX, np.ndarray, np.ndarray]:
    """The phases' boundary values as a statement's ends column
    (:meth:`~ocpkit.statement.phases.MultiPhaseProblem.ends_layout`): ``(z, q, e, variables, constants)``, ``e`` the column in the NLP symbols ``z`` (at ``variables``)
    and the block constants ``q`` (``constants``)."""
    zs, qs, es, variables, constants = [], [], [], [], []
    for p in phases:
        z, q, x0, xf, t0, tf, P = p.layout.boundary_symbols()
        zs.append(z)
        qs.append(q)
        es.append(ca.vertcat(x0, xf, t0, tf, P))
        variables.append(p.to_global[p.layout.boundary_variables()])
        constants.extend(p.layout.constants)
    return (
        ca.vertcat(*zs),
        ca.vertcat(*qs),
        ca.vertcat(*es),
        np.concatenate(variables).astype(np.int64),
        np.array(constants, dtype=float),
    )


def trajectory_blocks(
    statement: MultiPhaseProblem, phases: Sequence[Phase], row: int
) -> tuple[list[Block], ca.Function | None]:
    """The trajectory's cost (divided by its objective scale) and its linkage rows from ``row``; and the cost as a
    function ``(z, q) -> J`` (the problem's units; None without one)."""
    if statement.cost is None and statement.linkage is None:
        return [], None
    z, q, e, variables, constants = ends_function(phases)
    var, par = variables[:, None], constants[:, None]
    blocks: list[Block] = []
    cost = None
    if statement.cost is not None:
        J = statement.cost(e)
        cost = ca.Function("trajectory_cost", [z, q], [J])
        fun = ca.Function("trajectory_cost", [z, q], [J / statement.objective_scale])
        blocks.append(Block("trajectory_cost", fun, var, par))
    if statement.linkage is not None:
        linkage = statement.linkage
        out = linkage.function(e, ca.SX(0, 1)) / ca.DM(linkage.scale)
        rows = row + np.arange(linkage.size)[:, None]
        blocks.append(Block("linkage_constraints", ca.Function("linkage", [z, q], [out]), var, par, rows))
    return blocks, cost


__all__ = [
    "constraint_blocks",
    "ends_function",
    "globalised",
    "link_blocks",
    "mayer_block",
    "phase_blocks",
    "trajectory_blocks",
]
