"""Butcher tableaus of every emitted Runge-Kutta method, as data.

Input: nothing. Output: the fixed-step explicit tableaus (`Explicit`: `RK2`, `RK4`, every one
listed in `EXPLICIT`), with exact rational coefficients; `DOPRI5`, Dormand and Prince's 5(4)
pair with Shampine's continuous extension (`EmbeddedPair`); and `DOP853`, the explicit
Runge-Kutta pair of order 8 with error
estimators of orders 5 and 3 of E. Hairer, S. P. Norsett and G. Wanner, Solving Ordinary
Differential Equations I (2nd ed., Springer 1993), Section II.10, and its continuous extension
of order 7 (three more stages), with the constants of Hairer's code dop853.f (30 digits, as
printed there). The printers turn the tableau into the stage sums of the emitted C and NumPy
(only the non-zero entries), so both languages read the same numbers; tests/test_dop853.py
checks every order condition of the three weight vectors and the extension's accuracy.

Adding a fixed-step explicit method is one `Explicit` here (its nodes are checked against the
row sums of a) and one row in s2gen.methods; the printers, drivers and reference read them.

Example:
    >>> RK4.stages, RK4.b
    (4, (Fraction(1, 6), Fraction(1, 3), Fraction(1, 3), Fraction(1, 6)))
    >>> DOPRI5.stages, DOPRI5.e[6]
    (7, Fraction(-1, 40))
    >>> DOP853.stages, len(DOP853.a[11]), round(sum(DOP853.b), 12)
    (12, 11, 1.0)
    >>> [i for i, e in enumerate(DOP853.e3) if e]
    [0, 5, 6, 7, 8, 9, 10, 11]
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction as F

__all__ = [
    "DOP853",
    "DOPRI5",
    "EXPLICIT",
    "RK2",
    "RK3",
    "RK4",
    "EmbeddedPair",
    "Explicit",
    "Tableau",
]


def _check_rows(a: tuple[tuple[F, ...], ...], c: tuple[F, ...], what: str) -> None:
    """Row i of a strictly lower triangular a has i entries that add up to c_i."""
    if len(c) != len(a) or any(len(row) != i for i, row in enumerate(a)):
        raise ValueError(f"{what}: row i of a must have i entries, one row per node")
    if any(sum(row, F(0)) != ci for row, ci in zip(a, c)):
        raise ValueError(f"{what}: the nodes c must be the row sums of a")


@dataclass(frozen=True)
class Explicit:
    """A fixed-step explicit Runge-Kutta method for an autonomous field, coefficients exact.

    `a[i]` holds the coefficients of stage i on stages 0..i-1 (`a[0]` is empty), `c` the nodes
    (the row sums of a), `b` the weights; `order` its order, `title` what it is and who made it.
    `name` is an identifier (it names the emitted step function).

    Example:
        >>> Explicit("euler", 1, "Euler's method", ((),), (F(1),), (F(0),)).stages
        1
    """

    name: str
    order: int
    title: str
    a: tuple[tuple[F, ...], ...]
    b: tuple[F, ...]
    c: tuple[F, ...]

    def __post_init__(self) -> None:
        if not self.name.isidentifier():
            raise ValueError(f"tableau name {self.name!r} must be an identifier")
        _check_rows(self.a, self.c, self.name)
        if len(self.b) != len(self.c) or sum(self.b, F(0)) != 1:
            raise ValueError(f"{self.name}: one weight per stage, adding up to 1")

    @property
    def stages(self) -> int:
        """Field evaluations per step."""
        return len(self.b)


#: The explicit midpoint rule (Runge 1895), order 2.
RK2 = Explicit("rk2", 2, "explicit midpoint rule", ((), (F(1, 2),)), (F(0), F(1)), (F(0), F(1, 2)))
#: The classical Runge-Kutta method (Kutta 1901), order 4.
RK4 = Explicit(
    "rk4",
    4,
    "classical Runge-Kutta",
    ((), (F(1, 2),), (F(0), F(1, 2)), (F(0), F(0), F(1))),
    (F(1, 6), F(1, 3), F(1, 3), F(1, 6)),
    (F(0), F(1, 2), F(1, 2), F(1)),
)
#: A. Ralston, Runge-Kutta methods with minimum error bounds, Math. Comp. 16 (1962) 431-437:
#: the third-order method of least error bound.
RK3 = Explicit(
    "rk3",
    3,
    "Ralston's third-order method",
    ((), (F(1, 2),), (F(0), F(3, 4))),
    (F(2, 9), F(1, 3), F(4, 9)),
    (F(0), F(1, 2), F(3, 4)),
)
#: Every fixed-step explicit tableau.
EXPLICIT: tuple[Explicit, ...] = (RK2, RK4, RK3)


@dataclass(frozen=True)
class EmbeddedPair:
    """An explicit pair with FSAL whose last stage is evaluated at the solution.

    `a` as in `Explicit`, its last row the weights of the solution (order `order`); `e` the
    error weights (solution minus the embedded one); `dense[i]` the coefficients of sigma,
    sigma^2, sigma^3, sigma^4 in the weight of stage i of the continuous extension.

    Example:
        >>> tuple(sum(row, F(0)) for row in DOPRI5.dense) == (*DOPRI5.a[-1], 0)  # sigma = 1
        True
    """

    name: str
    order: int
    a: tuple[tuple[F, ...], ...]
    c: tuple[F, ...]
    e: tuple[F, ...]
    dense: tuple[tuple[F, ...], ...]

    def __post_init__(self) -> None:
        _check_rows(self.a, self.c, self.name)

    @property
    def stages(self) -> int:
        """Stages of one step, the FSAL stage included."""
        return len(self.a)


#: J. R. Dormand and P. J. Prince, A family of embedded Runge-Kutta formulae, J. Comput. Appl.
#: Math. 6 (1980) 19-26: the 5(4) pair with FSAL, and L. F. Shampine's continuous extension
#: of order 4 (Math. Comp. 46 (1986) 135-150) as in MATLAB's ode45.
DOPRI5 = EmbeddedPair(
    "dopri5",
    5,
    (
        (),
        (F(1, 5),),
        (F(3, 40), F(9, 40)),
        (F(44, 45), F(-56, 15), F(32, 9)),
        (F(19372, 6561), F(-25360, 2187), F(64448, 6561), F(-212, 729)),
        (F(9017, 3168), F(-355, 33), F(46732, 5247), F(49, 176), F(-5103, 18656)),
        (F(35, 384), F(0), F(500, 1113), F(125, 192), F(-2187, 6784), F(11, 84)),
    ),
    (F(0), F(1, 5), F(3, 10), F(4, 5), F(8, 9), F(1), F(1)),
    (F(71, 57600), F(0), F(-71, 16695), F(71, 1920), F(-17253, 339200), F(22, 525), F(-1, 40)),
    (
        (F(1), F(-183, 64), F(37, 12), F(-145, 128)),
        (F(0), F(0), F(0), F(0)),
        (F(0), F(1500, 371), F(-1000, 159), F(1000, 371)),
        (F(0), F(-125, 32), F(125, 12), F(-375, 64)),
        (F(0), F(9477, 3392), F(-729, 106), F(25515, 6784)),
        (F(0), F(-11, 7), F(11, 3), F(-55, 28)),
        (F(0), F(3, 2), F(-4), F(5, 2)),
    ),
)


@dataclass(frozen=True)
class Tableau:
    """An explicit Runge-Kutta pair for an autonomous field, with FSAL.

    `a[i]` holds the coefficients of stage i on stages 0..i-1 (`a[0]` is empty), `c` the nodes,
    `b` the weights of the solution (order `order`), `e5` and `e3` the weights of two error
    estimates (b minus weights of orders 5 and 3). The field at the new solution is the next
    step's first stage (stage s = `stages`). The continuous extension adds stages s+1, s+2, ...
    with coefficients `dense_a` (on stages 0..s, s+1, ...) and nodes `dense_c`; `dense_d` are
    the coefficients (on stages 0 .. s + len(dense_a)) of the last four terms of dop853.f's
    interpolation polynomial.
    """

    name: str
    order: int
    a: tuple[tuple[float, ...], ...]
    c: tuple[float, ...]
    b: tuple[float, ...]
    e5: tuple[float, ...]
    e3: tuple[float, ...]
    dense_a: tuple[tuple[float, ...], ...] = ()
    dense_c: tuple[float, ...] = ()
    dense_d: tuple[tuple[float, ...], ...] = ()

    @property
    def stages(self) -> int:
        return len(self.b)


def _f(text: str) -> float:
    return float(text)


# dop853.f: C2..C12 (C1 = 0, C12 = 1)
_C = (
    "0",
    "0.526001519587677318785587544488e-01",
    "0.789002279381515978178381316732e-01",
    "0.118350341907227396726757197510e+00",
    "0.281649658092772603273242802490e+00",
    "0.333333333333333333333333333333e+00",
    "0.25e+00",
    "0.307692307692307692307692307692e+00",
    "0.651282051282051282051282051282e+00",
    "0.6e+00",
    "0.857142857142857142857142857142e+00",
    "1",
)

# dop853.f: the non-zero A(i, j), stage i (1-based) on stage j
_A = {
    (2, 1): "5.26001519587677318785587544488e-2",
    (3, 1): "1.97250569845378994544595329183e-2",
    (3, 2): "5.91751709536136983633785987549e-2",
    (4, 1): "2.95875854768068491816892993775e-2",
    (4, 3): "8.87627564304205475450678981324e-2",
    (5, 1): "2.41365134159266685502369798665e-1",
    (5, 3): "-8.84549479328286085344864962717e-1",
    (5, 4): "9.24834003261792003115737966543e-1",
    (6, 1): "3.7037037037037037037037037037e-2",
    (6, 4): "1.70828608729473871279604482173e-1",
    (6, 5): "1.25467687566822425016691814123e-1",
    (7, 1): "3.7109375e-2",
    (7, 4): "1.70252211019544039314978060272e-1",
    (7, 5): "6.02165389804559606850219397283e-2",
    (7, 6): "-1.7578125e-2",
    (8, 1): "3.70920001185047927108779319836e-2",
    (8, 4): "1.70383925712239993810214054705e-1",
    (8, 5): "1.07262030446373284651809199168e-1",
    (8, 6): "-1.53194377486244017527936158236e-2",
    (8, 7): "8.27378916381402288758473766002e-3",
    (9, 1): "6.24110958716075717114429577812e-1",
    (9, 4): "-3.36089262944694129406857109825e0",
    (9, 5): "-8.68219346841726006818189891453e-1",
    (9, 6): "2.75920996994467083049415600797e1",
    (9, 7): "2.01540675504778934086186788979e1",
    (9, 8): "-4.34898841810699588477366255144e1",
    (10, 1): "4.77662536438264365890433908527e-1",
    (10, 4): "-2.48811461997166764192642586468e0",
    (10, 5): "-5.90290826836842996371446475743e-1",
    (10, 6): "2.12300514481811942347288949897e1",
    (10, 7): "1.52792336328824235832596922938e1",
    (10, 8): "-3.32882109689848629194453265587e1",
    (10, 9): "-2.03312017085086261358222928593e-2",
    (11, 1): "-9.3714243008598732571704021658e-1",
    (11, 4): "5.18637242884406370830023853209e0",
    (11, 5): "1.09143734899672957818500254654e0",
    (11, 6): "-8.14978701074692612513997267357e0",
    (11, 7): "-1.85200656599969598641566180701e1",
    (11, 8): "2.27394870993505042818970056734e1",
    (11, 9): "2.49360555267965238987089396762e0",
    (11, 10): "-3.0467644718982195003823669022e0",
    (12, 1): "2.27331014751653820792359768449e0",
    (12, 4): "-1.05344954667372501984066689879e1",
    (12, 5): "-2.00087205822486249909675718444e0",
    (12, 6): "-1.79589318631187989172765950534e1",
    (12, 7): "2.79488845294199600508499808837e1",
    (12, 8): "-2.85899827713502369474065508674e0",
    (12, 9): "-8.87285693353062954433549289258e0",
    (12, 10): "1.23605671757943030647266201528e1",
    (12, 11): "6.43392746015763530355970484046e-1",
}

# dop853.f: B1, B6..B12 (order 8)
_B = {
    1: "5.42937341165687622380535766363e-2",
    6: "4.45031289275240888144113950566e0",
    7: "1.89151789931450038304281599044e0",
    8: "-5.8012039600105847814672114227e0",
    9: "3.1116436695781989440891606237e-1",
    10: "-1.52160949662516078556178806805e-1",
    11: "2.01365400804030348374776537501e-1",
    12: "4.47106157277725905176885569043e-2",
}

# dop853.f: BHH1..BHH3, weights of order 3 on stages 1, 9 and 12
_BHH = {
    1: "0.244094488188976377952755905512e+00",
    9: "0.733846688281611857341361741547e+00",
    12: "0.220588235294117647058823529412e-01",
}

# dop853.f: ER1, ER6..ER12, the 5th-order error estimate (b minus weights of order 5)
_ER = {
    1: "0.1312004499419488073250102996e-01",
    6: "-0.1225156446376204440720569753e+01",
    7: "-0.4957589496572501915214079952e+00",
    8: "0.1664377182454986536961530415e+01",
    9: "-0.3503288487499736816886487290e+00",
    10: "0.3341791187130174790297318841e+00",
    11: "0.8192320648511571246570742613e-01",
    12: "-0.2235530786388629525884427845e-01",
}


# dop853.f: the continuous extension. C14..C16 and A(i, j) of stages 14..16 on stages 1..15
# (stage 13 is the field at the new solution)
_C_DENSE = ("0.1e+00", "0.2e+00", "0.777777777777777777777777777778e+00")
_A_DENSE = {
    (14, 1): "5.61675022830479523392909219681e-2",
    (14, 7): "2.53500210216624811088794765333e-1",
    (14, 8): "-2.46239037470802489917441475441e-1",
    (14, 9): "-1.24191423263816360469010140626e-1",
    (14, 10): "1.5329179827876569731206322685e-1",
    (14, 11): "8.20105229563468988491666602057e-3",
    (14, 12): "7.56789766054569976138603589584e-3",
    (14, 13): "-8.298e-3",
    (15, 1): "3.18346481635021405060768473261e-2",
    (15, 6): "2.83009096723667755288322961402e-2",
    (15, 7): "5.35419883074385676223797384372e-2",
    (15, 8): "-5.49237485713909884646569340306e-2",
    (15, 11): "-1.08347328697249322858509316994e-4",
    (15, 12): "3.82571090835658412954920192323e-4",
    (15, 13): "-3.40465008687404560802977114492e-4",
    (15, 14): "1.41312443674632500278074618366e-1",
    (16, 1): "-4.28896301583791923408573538692e-1",
    (16, 6): "-4.69762141536116384314449447206e0",
    (16, 7): "7.68342119606259904184240953878e0",
    (16, 8): "4.06898981839711007970213554331e0",
    (16, 9): "3.56727187455281109270669543021e-1",
    (16, 13): "-1.39902416515901462129418009734e-3",
    (16, 14): "2.9475147891527723389556272149e0",
    (16, 15): "-9.15095847217987001081870187138e0",
}

# dop853.f: D4j..D7j, j = 1, 6..16
_D_DENSE = {
    4: {
        1: "-0.84289382761090128651353491142e+01",
        6: "0.56671495351937776962531783590e+00",
        7: "-0.30689499459498916912797304727e+01",
        8: "0.23846676565120698287728149680e+01",
        9: "0.21170345824450282767155149946e+01",
        10: "-0.87139158377797299206789907490e+00",
        11: "0.22404374302607882758541771650e+01",
        12: "0.63157877876946881815570249290e+00",
        13: "-0.88990336451333310820698117400e-01",
        14: "0.18148505520854727256656404962e+02",
        15: "-0.91946323924783554000451984436e+01",
        16: "-0.44360363875948939664310572000e+01",
    },
    5: {
        1: "0.10427508642579134603413151009e+02",
        6: "0.24228349177525818288430175319e+03",
        7: "0.16520045171727028198505394887e+03",
        8: "-0.37454675472269020279518312152e+03",
        9: "-0.22113666853125306036270938578e+02",
        10: "0.77334326684722638389603898808e+01",
        11: "-0.30674084731089398182061213626e+02",
        12: "-0.93321305264302278729567221706e+01",
        13: "0.15697238121770843886131091075e+02",
        14: "-0.31139403219565177677282850411e+02",
        15: "-0.93529243588444783865713862664e+01",
        16: "0.35816841486394083752465898540e+02",
    },
    6: {
        1: "0.19985053242002433820987653617e+02",
        6: "-0.38703730874935176555105901742e+03",
        7: "-0.18917813819516756882830838328e+03",
        8: "0.52780815920542364900561016686e+03",
        9: "-0.11573902539959630126141871134e+02",
        10: "0.68812326946963000169666922661e+01",
        11: "-0.10006050966910838403183860980e+01",
        12: "0.77771377980534432092869265740e+00",
        13: "-0.27782057523535084065932004339e+01",
        14: "-0.60196695231264120758267380846e+02",
        15: "0.84320405506677161018159903784e+02",
        16: "0.11992291136182789328035130030e+02",
    },
    7: {
        1: "-0.25693933462703749003312586129e+02",
        6: "-0.15418974869023643374053993627e+03",
        7: "-0.23152937917604549567536039109e+03",
        8: "0.35763911791061412378285349910e+03",
        9: "0.93405324183624310003907691704e+02",
        10: "-0.37458323136451633156875139351e+02",
        11: "0.10409964950896230045147246184e+03",
        12: "0.29840293426660503123344363579e+02",
        13: "-0.43533456590011143754432175058e+02",
        14: "0.96324553959188282948394950600e+02",
        15: "-0.39177261675615439165231486172e+02",
        16: "-0.14972683625798562581422125276e+03",
    },
}


def _dop853() -> Tableau:
    s = 12
    a = tuple(tuple(_f(_A.get((i + 1, j + 1), "0")) for j in range(i)) for i in range(s))
    b = tuple(_f(_B.get(i + 1, "0")) for i in range(s))
    e5 = tuple(_f(_ER.get(i + 1, "0")) for i in range(s))
    e3 = tuple(b[i] - _f(_BHH.get(i + 1, "0")) for i in range(s))
    dense_a = tuple(
        tuple(_f(_A_DENSE.get((i, j + 1), "0")) for j in range(i - 1)) for i in (14, 15, 16)
    )
    dense_d = tuple(tuple(_f(_D_DENSE[r].get(j + 1, "0")) for j in range(16)) for r in (4, 5, 6, 7))
    return Tableau(
        "dop853",
        8,
        a,
        tuple(_f(x) for x in _C),
        b,
        e5,
        e3,
        dense_a,
        tuple(_f(x) for x in _C_DENSE),
        dense_d,
    )


#: Dormand and Prince's 8(5,3) pair as in dop853.f.
DOP853 = _dop853()
