# The plots of `coopdyn log` (clients/cli/log_plot.py): a wrench component whose CSV carries its sigma
# gets a +-sigma band, drawn in the band colour exactly where sigma is nonzero; without sigma columns
# (or with sigma all zero) no band. What a panel draws of a long run is thinned to its pixel columns
# with the same envelope (each column's lowest and highest sample), and the rows of status `error`
# are gaps (NaN breaks) in every curve and band, in what the figure holds. Skipped (77) without
# matplotlib.
import os
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.join(os.environ["COOPDYN_SOURCE_DIR"], "clients", "cli"))
try:
    import numpy as np
    import matplotlib  # noqa: F401
    import log_plot
except ImportError:
    sys.exit(77)


def write_csv(path, sigma):
    comps = ["mx", "my", "mz", "fx", "fy", "fz"]
    names = ["t"] + [f"arm1.ee.{c}" for c in comps] + ([f"arm1.ee.sigma_{c}" for c in comps] if sigma is not None else [])
    with open(path, "w") as f:
        f.write("# scene test, sigma band\n# wrench arm1.ee: kind end_effector, frame arm1.tool, by load\n")
        f.write(",".join(names) + "\n")
        for k in range(200):
            t = k * 0.005
            row = [t] + [np.sin(3 * t + i) * 10 for i in range(6)] + ([sigma] * 6 if sigma is not None else [])
            f.write(",".join(repr(float(x)) for x in row) + "\n")


def band_pixels(png):
    """pixels of the band colour at BAND_ALPHA over white (where no line crosses)"""
    import matplotlib.colors as mc
    import matplotlib.image as mi
    img = mi.imread(png)[:, :, :3]
    want = 1.0 - log_plot.BAND_ALPHA * (1.0 - np.array(mc.to_rgb(log_plot.BAND_COLOR)))
    return int(np.sum(np.all(np.abs(img - want) < 0.02, axis=2)))


class LogPlotBands(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()

    def tearDown(self):
        self.tmp.cleanup()

    def plot(self, sigma):
        d = os.path.join(self.tmp.name, str(sigma))
        os.makedirs(d)
        write_csv(os.path.join(d, "steps.csv"), sigma)
        log_plot.main(["log_plot.py", d, os.path.join(d, "steps.csv")])
        return os.path.join(d, "wrenches.png")

    def test_band_where_sigma(self):
        self.assertEqual(log_plot.sigma_column("arm1.ee.fz"), "arm1.ee.sigma_fz")
        with_band = band_pixels(self.plot(1.5))
        self.assertGreater(with_band, 2000)  # six panels, each a band 3 N (N m) wide over 10
        self.assertEqual(band_pixels(self.plot(None)), 0)
        self.assertEqual(band_pixels(self.plot(0.0)), 0)
        # a wider sigma, a wider band
        self.assertGreater(band_pixels(self.plot(3.0)), 1.5 * with_band)


def write_error_csv(path, n=20000, duration=10.0, err=(4.0, 5.0)):
    """A daemon-like run of n rows: a sinusoid with one spike, error rows (zeros) in err; -> (t, fz, error)."""
    t = np.arange(n) * (duration / n)
    error = (t >= err[0]) & (t < err[1])
    fz = 20 * np.sin(2 * np.pi * 0.7 * t) + 5
    fz[n // 5] = 300.0  # a one-sample spike the envelope must keep
    fz[error] = 0.0
    comps = ["mx", "my", "mz", "fx", "fy", "fz"]
    with open(path, "w") as f:
        f.write("# scene test, error rows\n# wrench arm1.ee: kind end_effector, frame arm1.tool, by load\n")
        f.write(",".join(["t", "tau:arm1.q1"] + [f"arm1.ee.{c}" for c in comps] + [f"arm1.ee.sigma_{c}" for c in comps]
                         + ["status"]) + "\n")
        for k in range(n):
            v = 0.0 if error[k] else 1.0
            row = [repr(float(t[k])), repr(v)] + [repr(float(fz[k] * (i + 1) / 6)) for i in range(6)] + [repr(v)] * 6
            f.write(",".join(row + ["error" if error[k] else "ok"]) + "\n")
    return t, fz, error


def check_drawn(test, x, y, t, data, error, width, xlim, edge=None):
    """(x, y) drawn of samples (t, data): no value inside an error span, a NaN across it, and per
    pixel column the data's lowest and highest value (edge "lo" / "hi": a band's, only that one)."""
    test.assertLessEqual(len(x), 2 * (width + 4))  # thinned: about two points a column (and the gap)
    err_t = t[error]
    inside = (x >= err_t[0]) & (x <= err_t[-1])
    test.assertFalse(np.any(np.isfinite(y[inside])), "a value drawn in the error rows")
    before = np.flatnonzero(x < err_t[0])[-1]
    after = np.flatnonzero(x > err_t[-1])[0]
    test.assertTrue(np.any(np.isnan(y[before:after + 1])), "the curve is not broken across the error rows")
    col = lambda tt: np.floor((tt - xlim[0]) / (xlim[1] - xlim[0]) * width)
    cd, cx = col(t), col(x)
    for c in np.unique(cd[~error]):
        d = data[(cd == c) & ~error]
        dr = y[(cx == c) & np.isfinite(y)]
        if edge != "hi":
            test.assertEqual(dr.min(), d.min(), f"column {c}")
        if edge != "lo":
            test.assertEqual(dr.max(), d.max(), f"column {c}")


class LogPlotThinnedWithGaps(unittest.TestCase):
    def test_lines_and_band(self):
        t, fz, error = write_error_csv(os.devnull, n=20000)  # (the numbers only)
        y = np.where(error, np.nan, fz)
        xlim, width = (float(t[0]), float(t[-1])), 300
        x, yy = log_plot.lines(t, y, xlim, width)
        check_drawn(self, x, yy, t, fz, error, width, xlim)
        self.assertEqual(np.nanmax(yy), 300.0)  # the spike
        x, lo, hi = log_plot.band(t, y - 1, y + 1, xlim, width)
        check_drawn(self, x, lo, t, fz - 1, error, width, xlim, "lo")
        check_drawn(self, x, hi, t, fz + 1, error, width, xlim, "hi")
        # few samples: every one drawn as it is
        x, yy = log_plot.lines(t[:500], y[:500], (t[0], t[499]), width)
        np.testing.assert_array_equal(yy, y[:500])

    def test_figure_draws_gaps(self):
        with tempfile.TemporaryDirectory() as d:
            csv_path = os.path.join(d, "steps.csv")
            t, fz, error = write_error_csv(csv_path)
            figs = []
            close = log_plot.plt.close
            log_plot.plt.close = lambda fig=None: figs.append(fig) if hasattr(fig, "axes") else close(fig)
            try:
                log_plot.main(["log_plot.py", d, csv_path])
            finally:
                log_plot.plt.close = close
            self.assertTrue(os.path.exists(os.path.join(d, "wrenches.png")))
            fig = figs[0]
            xlim = (float(t[0]), float(t[-1]))
            checked = 0
            for ax in fig.axes:
                title = ax.get_title()
                if not ax.lines:
                    continue
                line = ax.lines[0]
                x, y = line.get_xdata(), line.get_ydata()
                width = log_plot.panel_width(fig, ax)
                if title.startswith("applied torques"):
                    check_drawn(self, x, y, t, np.ones_like(t), error, width, xlim)
                else:
                    i = ["mx", "my", "mz", "fx", "fy", "fz"].index(title.split(" ")[0])
                    check_drawn(self, x, y, t, fz * (i + 1) / 6, error, width, xlim)
                    band = ax.collections[0].get_paths()  # the +-sigma band: none of it in the error rows
                    for p in band:
                        v = p.vertices
                        self.assertFalse(np.any((v[:, 0] > t[error][0] + 1e-9) & (v[:, 0] < t[error][-1] - 1e-9)))
                checked += 1
            self.assertEqual(checked, 7)
            for f in figs:
                close(f)


if __name__ == "__main__":
    unittest.main()
