"""s2gen: equations, variational integrators and C/NumPy code for mechanics on (S^2)^n."""
