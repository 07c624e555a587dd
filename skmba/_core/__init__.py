"""The package's infrastructure: what every part below uses, knowing no GP.

Private: nothing here is a user's API. The layers contract in
``pyproject.toml`` keeps it at the bottom: it imports no other part of
skmba.

========================  ================================================
file                      holds
========================  ================================================
``linalg.py``             Cholesky, QR and Kronecker-eigen factorisations,
                          their errors, memory checks and worker counts
``threads.py``            the BLAS-thread policy (``blas_threads``)
``triangular.py``         a triangular solve that releases the GIL
``workspace.py``          scratch arrays reused by hot loops, per thread
``progress.py``           progress bars and messages (``verbose``)
``validation.py``         the parameter tables, argument checks, random
                          streams
``columns.py``            named columns: tables matched by name
``regression.py``         the DACE polynomial regression bases (Table 3.1)
``dace.py``               the base of the DACE correlation families
========================  ================================================
"""
