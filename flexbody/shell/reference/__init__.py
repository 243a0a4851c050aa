"""The readable numpy twin of the element kernels, with the paper's equation numbers, stage by stage with the
names of :mod:`flexbody.shell.kernels` (``points``, ``material``, ``geometric``, ``expansion``, ``congruence``,
``loops``). The fast kernels are tested against it to 1e-12."""
