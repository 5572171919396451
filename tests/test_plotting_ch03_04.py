"""Plotting helpers of chapters 03 and 04: marker ids that do not collide, the d^2
histogram's overflow, the inverse-observation cloud's legend."""

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from slamlib.course import plots, plots_ch03, plots_ch04  # noqa: E402
from slamlib.runs import load_run  # noqa: E402


def test_ids_of_close_markers_go_to_opposite_sides():
    world = load_run("arena_loop").world()
    fig, ax = plt.subplots()
    plots.plot_world(ax, world)
    side = {t.get_text(): t.xyann[0] for t in ax.texts}
    plt.close(fig)
    # 51 (1.99, 1.20) and 41 (2.10, 1.20) are 0.11 m apart; 31 and 21 0.21 m
    assert side["51"] < 0 < side["41"]
    assert side["31"] < 0 < side["21"]
    # a marker with no close neighbour keeps its label on the right
    assert side["0"] > 0 and side["61"] > 0


def test_d2_histogram_counts_the_overflow():
    fig, ax = plt.subplots()
    d2 = np.array([0.5, 1.0, 3.0, 25.0, 40.0, np.nan])
    over = plots_ch03.plot_d2_histogram(ax, d2, threshold=5.99, clip=20.0)
    plt.close(fig)
    assert over == 2 / 5


def test_inverse_cloud_legend_names_the_linearised_mean():
    rng = np.random.default_rng(0)
    cloud = rng.normal(size=(200, 2))
    fig, ax = plt.subplots()
    plots_ch04.plot_inverse_cloud(ax, cloud, np.zeros(2), np.eye(2), pose=[0.0, -2.0, 0.3])
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    plt.close(fig)
    assert "linearised mean" in labels and "sample mean" in labels
    assert any("86.5 %" in s for s in labels)
    assert ax.yaxis_inverted()
