"""The fast (numba) element kernels of the six-node shell, one module per stage of the element computation.

The stage names match the readable numpy twin in :mod:`flexbody.shell.reference`: ``points`` (kinematics at the
integration points), ``material`` (strains and stress resultants), ``geometric`` (the geometric stiffness),
``expansion`` (point operators expanded to element rows), ``congruence`` (the element quantities to the nodal
local frames) and ``loops`` (the loops over a chunk of elements, called from Python). The seven-node variant
(MITC7) has the same stages in :mod:`flexbody.shell.kernels.mitc7`.
"""
