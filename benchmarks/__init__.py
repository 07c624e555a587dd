"""Timings and accuracy checks of skmba against stated targets (not shipped).

Each ``bench_*`` module is a script: ``python benchmarks/bench_gp.py``,
``bench_calibration.py``, ``bench_sensor_design.py``, ``bench_threads.py``,
``bench_low_rank.py`` (module 3's two paths around their crossover);
``bench_peers`` (against surmise) imports ``bench_calibration`` and runs as
a module from the repository root, ``python -m benchmarks.bench_peers``.
Every script prints :func:`benchmarks._machine.machine_report` first: the
processor, the BLAS threads and three speed probes (Python, small and
large LAPACK), so that times from different machines can be compared
(``python benchmarks/_machine.py`` prints it alone).
The validity suite and its studies are in ``validation/``
(``python -m validation --help``).
"""
