"""Adaptive harmonic (1x and nx) vibration control locked to the shaft angle.

* :mod:`.laws` -- the update laws (steepest descent, Newton, weighted least squares) as matrices;
* :mod:`.identification` -- recursive least squares of the influence matrix;
* :mod:`.influence` -- the model's influence matrix over speed (the speed schedule);
* :mod:`.block` -- the per-sample controller block (DESIGN.md section 3);
* :mod:`.config` -- the ``harmonic:`` config section, validated;
* :mod:`.runout` -- simulated sensor runout (a harmonic disturbance only the sensors see).

Analyses: :mod:`rotor_avc.harmonic.lti` (the LTI equivalent, poles, robustness map).
"""
