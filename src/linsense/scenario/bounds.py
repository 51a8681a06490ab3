"""The drive's bounds that a scenario's rules and the drive's design share (their one home).

A plain module of numbers, below the design (:mod:`linsense.tune.design` imports them) and light to
import: the dead time's largest share of the PWM period, the injection's highest frequency and the
protection's bus limits as fractions of the bus.
"""

#: the dead time's largest share of the PWM period (docs/simulator.md, ``inverter.dead_time``): the
#: design's rule and the scenario's alike
DEAD_TIME_SHARE_MAX = 0.1
#: the injection's highest frequency, ``f_pwm / F_INJ_PWM_DIV`` (the demodulator's zeros at 2 f_inj
#: below the Nyquist rate): the design's rule and the scenario's alike
F_INJ_PWM_DIV = 4.0
V_DC_MIN_FRACTION = 5.0 / 9.0  # under-voltage limit, of the bus (40 V at 72 V)
V_DC_MAX_FRACTION = 5.0 / 4.0  # over-voltage limit (90 V at 72 V)
