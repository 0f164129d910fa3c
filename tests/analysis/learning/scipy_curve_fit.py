"""The reference for tests/analysis/learning/curve_fit_test.cc: scipy's
curve_fit (Levenberg-Marquardt, MINPACK) on the same data. Reads a CSV of
`trial,value` rows, fits FAMILY (power or exponential) from its own start
(the data's last value as plateau, first minus last as excess, rate 0.5 or
a third of the trials), and prints `a b rate se_a se_b se_rate`."""
import csv
import sys

import numpy as np
from scipy.optimize import curve_fit


def main():
    path, family = sys.argv[1], sys.argv[2]
    with open(path, newline="") as f:
        rows = [(float(r["trial"]), float(r["value"])) for r in csv.DictReader(f)]
    n = np.array([r[0] for r in rows])
    y = np.array([r[1] for r in rows])
    if family == "power":
        model = lambda n, a, b, c: a + b * n ** (-c)
        p0 = [y[-1], y[0] - y[-1], 0.5]
    else:
        model = lambda n, a, b, tau: a + b * np.exp(-n / tau)
        p0 = [y[-1], y[0] - y[-1], len(n) / 3.0]
    params, cov = curve_fit(model, n, y, p0=p0, maxfev=20000)
    se = np.sqrt(np.diag(cov))
    print(" ".join(repr(float(v)) for v in list(params) + list(se)))


if __name__ == "__main__":
    main()
