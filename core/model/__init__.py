"""The measurement model: what a sensor measures and the checks at the public boundary.

:mod:`.sensors` (:class:`core.Sensor`: the kind, noise and medium of a measurement),
:mod:`.fields` (the electric dipole's field and Jacobian), :mod:`.sea` (:class:`core.Sea`, the
layered sea), :mod:`.magnetic` (field, gradient tensor, invariants, Euler's formula),
:mod:`.measurement` (:class:`core.SensorModel`, the stacked measurement of tracking) and
:mod:`.validation`. Validated numpy fronts of :mod:`core.kernels`.
"""
