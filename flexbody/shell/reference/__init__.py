"""The readable numpy twin of the element kernels, with the paper's equation numbers, stage by stage with the
names of :mod:`flexbody.shell.kernels` (``points``, ``material``, ``geometric``, ``expansion``, ``congruence``,
``loops``), and ``bubble``, the seven-node variant (MITC7) whose fast twin is :mod:`flexbody.shell.kernels.mitc7`.
The fast kernels are tested against it to 1e-12. docs/theory.md maps each equation to both."""
