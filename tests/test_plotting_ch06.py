"""Chapter 06's plotting helpers: log axes that carry readable labels whatever their range, and
legends and event labels that hide no data."""

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from slamlib.course import plots_ch06  # noqa: E402


@pytest.mark.parametrize("lo, hi, at_least", [(2.5, 4.0, 3), (0.7, 1.4, 3), (2.2, 13.0, 3),
                                              (0.017, 0.35, 3), (0.0015, 900.0, 5)])
def test_a_log_axis_gets_labelled_ticks_inside_its_range(lo, hi, at_least):
    ticks = plots_ch06._PlainLogLocator().tick_values(lo, hi)
    assert len(ticks) >= at_least
    assert np.all((ticks >= lo) & (ticks <= hi)) and np.all(np.diff(ticks) > 0)
    # at most about ten labels: they must not crowd
    assert len(ticks) <= 10


def test_a_wide_log_axis_is_labelled_at_powers_of_ten_only():
    ticks = plots_ch06._PlainLogLocator().tick_values(0.0015, 900.0)
    np.testing.assert_allclose(ticks, [0.01, 0.1, 1.0, 10.0, 100.0])


def _curves():
    t = np.linspace(0.5, 60.0, 120)
    return {"EKF SLAM": (t, 3.0 + 0.3 * np.sin(t), 1.0 + 0.1 * np.cos(t)),
            "FEJ": (t, 3.1 + 0.2 * np.sin(t), 1.05 + 0.1 * np.cos(t))}


def test_plot_nees_averages_labels_its_axes_with_plain_numbers():
    fig, axes = plots_ch06.plot_nees_averages(_curves(), 100)
    fig.canvas.draw()
    for ax in axes:
        labels = [t.get_text() for t in ax.get_yticklabels() if t.get_text()]
        assert len(labels) >= 3                       # a range of 2.5-4 or 0.7-1.3
        assert all("10^" not in s and "times" not in s for s in labels)
        [float(s) for s in labels]                    # plain numbers, not 2 x 10^0
    plt.close(fig)


def test_plot_nees_averages_legend_below_and_events_above_the_axes():
    fig, axes = plots_ch06.plot_nees_averages(_curves(), 100, legend="below",
                                              events=((36.0, "marker 61 mapped"),
                                                      (48.0, "loop closure")))
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    assert axes[0].get_legend() is None and len(fig.legends) == 1
    lowest_axes = min(ax.get_window_extent(renderer).y0 for ax in axes)
    assert fig.legends[0].get_window_extent(renderer).y1 <= lowest_axes
    top = axes[0].get_window_extent(renderer).y1
    notes = [a for a in axes[0].texts if "marker 61" in a.get_text() or "loop" in a.get_text()]
    assert len(notes) == 2
    boxes = [a.get_window_extent(renderer) for a in notes]
    assert all(b.y0 >= top for b in boxes)            # above the data, not over it
    assert not boxes[0].overlaps(boxes[1])
    assert fig.get_figheight() > 3.4                  # room made for the legend
    plt.close(fig)


def test_plot_nees_averages_refuses_an_unknown_legend_place():
    with pytest.raises(ValueError, match="legend"):
        plots_ch06.plot_nees_averages(_curves(), 100, legend="left")


def test_plot_nees_averages_without_a_legend():
    fig, axes = plots_ch06.plot_nees_averages(_curves(), 100, legend="none")
    assert axes[0].get_legend() is None and not fig.legends
    plt.close(fig)



def test_a_marker_id_moves_away_from_a_landmark_mapped_close_to_it():
    from types import SimpleNamespace

    from slamlib.course import plots

    markers = [SimpleNamespace(id=28, x=3.0, y=2.7, yaw=0.0),
               SimpleNamespace(id=87, x=0.8, y=2.7, yaw=0.0)]
    world = SimpleNamespace(markers=markers, positions=np.array([[3.0, 2.7], [0.8, 2.7]]))
    fig, ax = plt.subplots()
    plots.plot_world(ax, world, facing=False)
    ax.invert_yaxis()                                   # the course's z-down top view
    # marker 28's landmark mapped 0.2 m to its right and 0.2 m up the screen (y points down):
    # on the default corner (up-right) the plus sign would cover the id
    plots_ch06.keep_ids_clear(ax, world, {28: (3.2, 2.5)})
    label = {t.get_text(): t for t in ax.texts}
    assert tuple(label["28"].get_position()) == (-4, -4)    # the corner away from it: down-left
    assert (label["28"].get_ha(), label["28"].get_va()) == ("right", "top")
    assert tuple(label["87"].get_position()) == (4, 4)      # nothing near marker 87: it stays
    plt.close(fig)


def test_plot_world_writes_no_id_for_a_skipped_marker():
    from types import SimpleNamespace

    from slamlib.course import plots

    markers = [SimpleNamespace(id=i, x=float(i), y=0.0, yaw=0.0) for i in (3, 5, 8)]
    world = SimpleNamespace(markers=markers, positions=np.array([[m.x, m.y] for m in markers]))
    fig, ax = plt.subplots()
    plots.plot_world(ax, world, facing=False, skip_ids={5})
    assert sorted(t.get_text() for t in ax.texts) == ["3", "8"]
    plt.close(fig)
