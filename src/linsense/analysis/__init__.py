"""What a motor model means for the HF estimate: the HF current response and its phase psi (paper
eq. 11), Psi_LUT (eq. 12), the saliency and the error gain (:mod:`~linsense.analysis.hf`), the same
for the rotating vector and the square wave (:mod:`~linsense.analysis.rotating`,
:mod:`~linsense.analysis.square`), the linearised loop's stability (:mod:`~linsense.analysis.stability`),
a motor's summary and its tables (:mod:`~linsense.analysis.summary`, :mod:`~linsense.analysis.model_table`),
and the back-EMF estimate's low-speed limit (:mod:`~linsense.analysis.emf`); docs/theory.md.
"""
