"""The end-effect compensation table (Psi_LUT) the drive reads: built from a motor model
(:func:`~linsense.compensation.lut.build_lut`, paper eq. 12 or its resistance-aware form), read from
a calibration (:mod:`~linsense.compensation.measured`, the stamped ``lut_measured.json``), and
exported to CSV, JSON and a C99 header stamped with the version and the data's SHA-256
(:mod:`~linsense.compensation.stamp`); docs/theory.md, docs/firmware.md.
"""
