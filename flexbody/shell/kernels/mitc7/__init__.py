"""The fast (numba) kernels of the seven-node bubble variant (MITC7), with the stage names of
:mod:`flexbody.shell.kernels`."""
