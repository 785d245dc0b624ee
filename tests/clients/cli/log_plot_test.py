# The plots of `coopdyn log` (clients/cli/log_plot.py): a wrench component whose CSV carries its sigma
# gets a +-sigma band, drawn in the band colour exactly where sigma is nonzero; without sigma columns
# (or with sigma all zero) no band. Skipped (77) without matplotlib.
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


if __name__ == "__main__":
    unittest.main()
