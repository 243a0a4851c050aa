"""The fast (numba) kernels of the seven-node bubble variant (MITC7), with the stage names of
:mod:`flexbody.shell.kernels`: the condensed MITC7 element (rotation bubble) for a batch of elements.

Computes, element by element, exactly what the readable numpy twin computes:
:func:`flexbody.shell.reference.loops.force_tangent` with ``bubble=b`` (the 38-component augmented force
and tangent, the last two components for the bubble amplitudes b) and
:func:`flexbody.shell.reference.bubble.condensed_force_tangent` (Newton on b, then static condensation)::

    r_b(b*) = 0  (Newton on the 2 x 2 block, from the warm start b0),
    f = r_n(b*),     K = K_nn - K_nb K_bb^-1 K_bn.

Contract: the force, the condensed tangent and b* agree with the numpy reference to 1e-12 relative
(tests/shell/test_element_bubble.py). Change the two together.

The modules, one per stage:

* :mod:`~flexbody.shell.kernels.mitc7.points`: the nodal relative rotations, the kinematics, covariant strains
  and pulled-back stress weights of the evaluation points, and the shape-function tables;
* :mod:`~flexbody.shell.kernels.mitc7.material`: the strain gradient D and the material stiffness;
* :mod:`~flexbody.shell.kernels.mitc7.geometric`: the contracted second variation K_xi of a point (the
  geometric stiffness in the 18 slots) and its bubble block;
* :mod:`~flexbody.shell.kernels.mitc7.expansion`: point operators in the 18 slots expanded into z;
* :mod:`~flexbody.shell.kernels.mitc7.congruence`: f_h = P^T f_z, K_h = P^T K_z P and the nodal terms of
  the derivative of P;
* :mod:`~flexbody.shell.kernels.mitc7.augmented`: the augmented element (38 motions) at a given b, and only
  its bubble block (for the Newton on b);
* :mod:`~flexbody.shell.kernels.mitc7.condensation`: Newton on b and the static condensation;
* :mod:`~flexbody.shell.kernels.mitc7.maps`: the kernels' form of the assumed-strain map;
* :mod:`~flexbody.shell.kernels.mitc7.loops`: the loop over a chunk of elements and
  :func:`~flexbody.shell.kernels.mitc7.loops.condensed_force_tangent_batch`, the entry point.

The arithmetic is that of the reference, arranged as in the MITC6 kernels (:mod:`flexbody.shell.kernels`);
results agree to round-off:

* **Relative coordinates.** The 38 augmented motions h = [u_I, theta_I, b] are mapped to
  z = [dx_I, dtheta_0, dd_1..dd_5, db], dx_I = R_I du_I, dd_I = T^-1(d_I) dtheta_I - T^-1(-d_I) dtheta_0
  (paper Eq. 31): z = P h. At an evaluation point the strains depend on z only through 18 slots
  xi = [dx_,r, dx_,s, dtheta_0, dd, dd_,r, dd_,s] = Pi_p z, Pi_p holding only the scalars N_I, dN_I (and
  N_b, dN_b for db). The Jacobian G (12 x 18), the B rows and the contracted second variation K_xi (18 x 18:
  G^T Hf G, written out from the sparsity of Hf, plus the terms of kinematics.second_variation) are formed
  in xi and expanded into z in two sparse stages; the material stiffness sum_g B_g^T (w tc^T C tc) B_g is
  formed in z (upper triangle, if C is symmetric). Then K_h = P^T K_z P plus the nodal terms of the
  derivative of P: hat(f_u,I) in (u_I, theta_I) and the D T^-1(+-d_I)[.] terms contracted with the z-force
  at dd_I (which equals the reference's sum over points of N_I g_d + dN_I . g_da).
* The stress weights of the evaluation points are pulled back once (as in the reference); the force is
  sum_p Pi_p^T G_p^T D_p^T s_p (equal to sum_g w_g B_g^T sigma_g), mapped back by P^T.
* **Bubble iterations.** During the bubble's Newton iterations only r_b (2,) and K_bb (2 x 2) are formed
  (``augmented.evaluate_bubble``: the same terms restricted to the db column of Pi_p); the force (38,) and,
  if wanted, the full tangent are formed once, at the final b, by ``augmented.evaluate_z`` (the force by the
  same code with and without the tangent).
* The SO(3) coefficients of a point (lk.coefficients of |d|; the same for -d) are computed once per point
  (the Taylor series below the switch evaluated fused), and the maps D T, D^2 T use them.
* Evaluation points that the assumed-strain map does not use are skipped. The per-point and per-element
  kernels are compiled with the flags of the MITC6 kernels (``fast``: no reference counting, noalias, FMA
  contraction); the node setup, the workspaces, the bubble's Newton and condensation and the chunk loop with
  numba's defaults (``plain``, ``released``).

SO(3) maps: :mod:`flexbody.lie.kernels` (same conventions as :mod:`flexbody.lie.so3`:
``d_tangent_into(phi, b, X)`` gives ``X v = (D T(phi)[v]) b`` etc.).
"""
