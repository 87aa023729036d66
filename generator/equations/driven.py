"""What a driven system's code needs: time and inputs as kernel inputs, and the kernels of its
forces and of the work they do.

Input: a `System` with forces, inputs or a time-dependent potential (`System.driven`).
Output: `Drive`, the record of the driven part the later stages read (inputs and defaults,
whether there are forces and whether they depend on the angular velocities), `tu_argument`
(the array ``tu`` every kernel that reads time or an input takes: ``tu[0]`` is t, ``tu[1 + k]``
input k) and `driven_kernels`, whole-system kernels:

- ``force``: F (3n, body-major) and, when F depends on w, its Jacobian Fw = dF/dw (3n x 3n,
  row-major), from the spec's forces summed per body;
- ``power``: P = dV/dt + sum_i F_i . (w_i x q_i), the rate of the work done on the system;
- ``fvel``: the forced VI's velocity terms at the end of a step, c_i = h/2 q_i+ x F_i+ and
  (velocity-dependent forces) its Jacobian h/2 hat(q_i+) dF_i/dw (3n x 3n);
- ``fstage``: the continuous field's force terms q_i x F_i.

How forces enter (the equations of `s2gen.equations.forced`): everywhere the conservative code
reads g = dV/dq the forced equations read g - F. At the start of a VI step that is known; at
its end the velocity equation A(q+) w+ = c - h/2 q+ x (g+ - F+) is affine in F+, so the
conservative step's w+ is corrected by A(q+)^-1 (h/2 q+ x F+), by Newton's method with the
Jacobian A - h/2 hat(q+) Fw when F+ depends on w+. The field's A(q) wdot = b gains q x F.

Example:
    >>> from s2gen.spec import define_system
    >>> s = define_system(name="spin", bodies=1, parameters={"c": 0.5}, inputs={"tau": 1.0},
    ...                   diagonal=["2"], potential="cos(t)*q1[2]",
    ...                   forces={"F1": "tau*cross(e3, q1) - c*cross(w1, q1)"})
    >>> d = drive_of(s)
    >>> d.inputs, d.velocity, [k.name for k in driven_kernels(s)]
    (('tau',), True, ['force', 'power', 'fvel', 'fstage'])
"""

from __future__ import annotations

import sympy as sp

from s2gen.equations.geometry import hat
from s2gen.ir import Argument, Drive, KernelDef, Output
from s2gen.symbols import TIME, q_symbols, w_symbol
from s2gen.system import System

__all__ = ["Drive", "drive_of", "driven_kernels", "tu_argument", "tu_symbols"]


def tu_symbols(system: System) -> tuple[sp.Symbol, ...]:
    """Time (a dummy when a parameter named t hides it), then the inputs."""
    time = sp.Dummy("time", real=True) if "t" in system.parameter_names else TIME
    return (time, *system.inputs.symbols)


def tu_argument(system: System, *exprs: sp.Expr) -> tuple[Argument, ...]:
    """``(tu,)`` when one of `exprs` reads time or an input, else ``()``."""
    if not system.driven:
        return ()
    symbols = tu_symbols(system)
    free = set().union(*(sp.sympify(e).free_symbols for e in exprs)) if exprs else set()
    return (Argument("tu", symbols),) if free & set(symbols) else ()


def _w_symbols(n: int) -> list[sp.Symbol]:
    return [w_symbol(i, c) for i in range(1, n + 1) for c in range(3)]


def _force_total(system: System) -> sp.Matrix:
    """The forces summed per body (3n x 1, body-major), parameters as symbols."""
    total = sp.zeros(3 * system.n, 1)
    for f in system.forces:
        for body, force in f.total(system.n):
            total[3 * body : 3 * body + 3, 0] += force
    return total


def drive_of(system: System) -> Drive:
    """The `Drive` of a driven system."""
    ws = set(_w_symbols(system.n))
    velocity = bool(system.forces) and bool(_force_total(system).free_symbols & ws)
    return Drive(system.inputs.names, system.inputs.values, bool(system.forces), velocity)


def driven_kernels(system: System) -> list[KernelDef]:
    """The kernels of the module docstring (``force`` and ``fvel``'s Jacobian only when
    needed)."""
    n = system.n
    p = Argument("p", system.parameter_symbols)
    q = Argument("q", tuple(q_symbols(n)))
    ws = _w_symbols(n)
    w = Argument("w", tuple(ws))
    F = Argument("F", tuple(sp.symbols(f"F_0:{3 * n}", real=True)))
    stages = (("p", 0),)
    dvdt = sp.diff(system.full_potential(), tu_symbols(system)[0])
    kernels: list[KernelDef] = []
    power = dvdt
    if system.forces:
        total = _force_total(system)
        drive = drive_of(system)
        outputs = [Output("F", tuple(total))]
        if drive.velocity:
            jac = total.jacobian(ws)
            outputs.append(
                Output("Fw", tuple(jac[r, c] for r in range(3 * n) for c in range(3 * n)))
            )
        kernels.append(
            KernelDef(
                "force",
                "generalized forces F (body-major) and, velocity-dependent, dF/dw (row-major)",
                (p, q, w, *tu_argument(system, *total)),
                tuple(outputs),
                system=True,
                stages=stages,
            )
        )
        qv = [sp.Matrix(q.symbols[3 * i : 3 * i + 3]) for i in range(n)]
        wv = [sp.Matrix(ws[3 * i : 3 * i + 3]) for i in range(n)]
        Fv = [sp.Matrix(F.symbols[3 * i : 3 * i + 3]) for i in range(n)]
        power += sum((Fv[i].dot(wv[i].cross(qv[i])) for i in range(n)), sp.Integer(0))
        kernels.append(
            KernelDef(
                "power",
                "the power P = dV/dt + sum_i F_i . (w_i x q_i)",
                (p, q, w, F, *tu_argument(system, power)),
                (Output("pw", (power,), scalar=True),),
                system=True,
                stages=stages,
            )
        )
        h = sp.Symbol("h", positive=True)
        c = [h / 2 * qv[i].cross(Fv[i]) for i in range(n)]
        fvel_out = [Output("c", tuple(e for v in c for e in v))]
        fvel_in = [Argument("h", (h,), scalar=True), q, F]
        if drive.velocity:
            Fw = sp.Matrix(3 * n, 3 * n, sp.symbols(f"Fw_0:{9 * n * n}", real=True))
            blocks = sp.zeros(3 * n, 3 * n)
            for i in range(n):
                blocks[3 * i : 3 * i + 3, :] = h / 2 * hat(qv[i]) * Fw[3 * i : 3 * i + 3, :]
            fvel_in.append(Argument("Fw", tuple(Fw)))
            fvel_out.append(Output("jc", tuple(blocks)))
        kernels.append(
            KernelDef(
                "fvel",
                "the forced VI's end velocity terms h/2 q_i x F_i (and their Jacobian in w)",
                tuple(fvel_in),
                tuple(fvel_out),
                system=True,
            )
        )
        kernels.append(
            KernelDef(
                "fstage",
                "the force terms q_i x F_i of the continuous field's right side b",
                (q, F),
                (Output("b", tuple(e for i in range(n) for e in qv[i].cross(Fv[i]))),),
                system=True,
            )
        )
    else:
        kernels.append(
            KernelDef(
                "power",
                "the power P = dV/dt",
                (p, q, *tu_argument(system, power)),
                (Output("pw", (power,), scalar=True),),
                system=True,
                stages=stages,
            )
        )
    return kernels
