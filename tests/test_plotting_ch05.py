"""Chapter 05's plotting helpers mark exactly the wrong map entries."""

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from slamlib.course import plots, plots_ch05  # noqa: E402


class _World:
    def landmarks(self):
        return {1: np.array([0.0, 0.0]), 2: np.array([1.0, 0.0]), 3: np.array([0.0, 2.0])}


class _Map:
    landmarks = {1: np.array([0.05, 0.0]),      # 5 cm off: fine
                 2: np.array([1.0, 0.5]),       # 0.5 m off: misplaced
                 7: np.array([3.0, 3.0])}       # not in the world


def test_plot_map_errors_marks_misplaced_and_spurious_ids():
    fig, ax = plt.subplots()
    misplaced, spurious = plots_ch05.plot_map_errors(ax, _Map(), _World(), threshold=0.3)
    assert misplaced == [2] and spurious == [7]
    assert len(ax.lines) == 2
    np.testing.assert_allclose(ax.lines[0].get_xydata(), [[1.0, 0.5], [1.0, 0.0]])
    misplaced, _ = plots_ch05.plot_map_errors(ax, _Map(), _World(), threshold=0.01, legend=False)
    assert misplaced == [1, 2]
    plt.close(fig)


def test_plot_error_comparison_draws_the_position_error_norm():
    class T:
        t = np.array([0.0, 1.0])
        error = np.array([[0.3, 0.4, 0.1], [0.0, 0.0, -0.2]])

    fig, axes = plots.plot_error_comparison({"a": T()}, marks=[0.5], mark_label="m")
    np.testing.assert_allclose(axes[0].lines[0].get_ydata(), [0.5, 0.0])
    np.testing.assert_allclose(axes[1].lines[0].get_ydata(), np.degrees([0.1, -0.2]))
    plt.close(fig)


class _Run:
    """A trace with three instants: errors ``scale`` times a fixed pattern, sigma 0.2."""

    def __init__(self, scale):
        self.t = np.array([0.0, 1.0, 2.0])
        self.error = scale * np.array([[0.1, 0.2, 0.01], [0.0, -0.1, 0.02], [0.3, 0.0, -0.03]])
        self.sigma = np.full((3, 3), 0.2)


def test_plot_errors_against_draws_both_runs_and_one_band():
    run, ref = _Run(1.0), _Run(-2.0)
    fig, axes = plots_ch05.plot_errors_against(run, ref, label="run", reference_label="ref")
    assert len(axes) == 3
    for i, ax in enumerate(axes):
        np.testing.assert_allclose(ax.lines[0].get_ydata(), ref.error[:, i])   # grey, underneath
        np.testing.assert_allclose(ax.lines[1].get_ydata(), run.error[:, i])
        assert len(ax.collections) == 1                                       # only the run's band
    labels = axes[0].get_legend_handles_labels()[1]
    assert labels[:2] == ["ref", "run"]
    assert labels[2] == "$\\pm2\\sigma$"                                   # the default band label
    plt.close(fig)


def test_plot_errors_against_names_the_band():
    fig, axes = plots_ch05.plot_errors_against(_Run(1.0), _Run(-2.0), label="run",
                                               reference_label="ref", band_label="run's band")
    for ax in axes:
        assert len(ax.collections) == 1
        assert ax.collections[0].get_label() == "run's band"
    legend = [t.get_text() for t in axes[0].get_legend().get_texts()]
    assert legend == ["ref", "run", "run's band"]
    plt.close(fig)
