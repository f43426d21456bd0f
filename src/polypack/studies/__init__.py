"""Studies of the seed documents: one module per study (the run engine in :mod:`polypack.ensemble`
knows none of them).

``seed003_heterogeneity``  Table 2, Figs. 2 and 6 and the power law Eq. (7) of 003_873b69fc71c74cf6.txt
                           (``[sweep] report = "heterogeneity"``).
"""
