"""Identification from bench data: a bench file's phasors (or amplitudes) per position become the
inductance table, a fitted motor model and the measured compensation table (``linsense identify``,
``linsense bench-emulate``; docs/identify.md).

Modules: :mod:`~linsense.identify.bench` (the bench file: read, emulate, write),
:mod:`~linsense.identify.process` (phasors -> inductance matrix per position),
:mod:`~linsense.identify.fit` (the model of docs/theory.md section 2 fitted to them),
:mod:`~linsense.identify.emf_record` and :mod:`~linsense.identify.open_circuit` (the open-circuit
back-EMF record -> the magnets' flux per phase),
:mod:`~linsense.identify.measured_outputs` and :mod:`~linsense.identify.identification` (the whole job and its
outputs).
"""
