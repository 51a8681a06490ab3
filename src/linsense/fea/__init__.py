"""Axisymmetric finite-element analysis of tubular linear motors (scikit-fem; the ``fea`` extra):
a geometry file (:mod:`~linsense.fea.geometry`) meshed and solved for the phase flux linkages over
the stroke (:mod:`~linsense.fea.solver`), the inductance table and the magnets' polarity
(:mod:`~linsense.fea.polarity`) written as a motor file (:mod:`~linsense.fea.outputs`,
:mod:`~linsense.fea.per_load`; ``linsense fea``, docs/fea.md).
"""
