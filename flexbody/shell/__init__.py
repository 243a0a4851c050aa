"""The six-node SE(3) shell element: geometry, kinematics, MITC6 tying, material, element kernels, and the
element variants as objects (variants.py)."""
