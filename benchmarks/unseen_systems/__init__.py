"""Emitted C against hand-written C on three systems the tests never see.

``python benchmarks/unseen.py [--launches 5]`` emits each system with s2gen, builds the
emitted C (driven through ``NAME_integrate``) and a hand-written C99 program of the same
variational integrator with the same gcc flags in two flavours (``-O2``; ``-O3
-march=native``), checks that both end in the same state, and prints per-step times, their
ratio and Newton iterations per step from alternating launches.

The systems (TOML specs beside this module, written by `specs`):

- ``yukawa.toml``: 100 charges on the sphere with per-body masses and charges, a screened
  Coulomb pair potential A c_i c_j exp(-kappa r_ij)/r_ij over all 4950 pairs and a field term;
  diagonal inertia, so the explicit VI (hand-written: ``yukawa.c``);
- ``chain.toml``: a chain of 10 spherical pendula with a dense inertia, gravity and springs
  between neighbours; the implicit VI, Newton on 30 Cayley parameters (``chain.c``);
- ``mixture.toml``: 2000 Lennard-Jones particles of two species with per-body masses, sizes
  and strengths (Lorentz-Berthelot mixing in the pair term) over the pairs within a cutoff;
  diagonal inertia, the explicit VI (hand-written with sorted cell lists: ``mixture.c``).

Modules: `specs` (the TOML files from closed formulas), `cases` (the cases and the C data
headers read from the loaded System), `programs` (build and run both programs); ``../unseen.py``
(alternating launches and the table) runs them. ``emitted_driver.c`` is the driver of the
emitted C.

Example:
    >>> sorted(CASES)
    ['chain', 'mixture', 'yukawa']
"""

from unseen_systems.cases import CASES, Case

__all__ = ["CASES", "Case"]
