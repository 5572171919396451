"""Chapter 07's figures: the return rule's sketch draws what Explorer decides, and a return
cut off by the end of a run is marked apart from the finished ones."""

import matplotlib

matplotlib.use("Agg")

from types import SimpleNamespace  # noqa: E402

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from slamlib.course import plots_ch07  # noqa: E402


def _by_gid(ax, gid):
    found = [a for a in ax.get_children() if a.get_gid() == gid]
    assert len(found) == 1, gid
    return found[0]


def test_the_sketch_draws_the_rules_own_anchor_and_goals():
    sk = plots_ch07.return_rule_sketch()
    ex = sk.explorer
    # the anchor, chosen by hand from the rule's definition: enough sightings, sigma below
    # anchor_ratio * sigma_xy, the nearest of those
    ok = [i for i, (p, s, ang) in sk.landmarks.items()
          if len(ang) >= ex.min_sightings and s < ex.anchor_ratio * sk.sigma_xy]
    near = min(ok, key=lambda i: np.hypot(*(np.asarray(sk.landmarks[i][0]) - sk.pose[:2])))
    assert sk.anchor == near == 1
    assert sk.sigma_xy > ex.sigma_return
    # the scene shows each way of being passed over: too uncertain, too few frames, farther
    dist = {i: np.hypot(*(np.asarray(p) - sk.pose[:2])) for i, (p, _, _) in sk.landmarks.items()}
    assert sk.landmarks[2][1] >= ex.anchor_ratio * sk.sigma_xy and dist[2] < dist[1]
    assert len(sk.landmarks[3][2]) < ex.min_sightings and dist[3] < dist[1]
    assert 4 in ok and dist[4] > dist[1]
    # the goals, from the module's formula: return_distance along the mean sighting, then approach
    a = np.asarray(sk.landmarks[1][0])
    side = sk.sightings[1].mean(axis=0)
    view = a + ex.return_distance * side / np.hypot(*side)
    closer = view + ex.approach * (a - view) / ex.return_distance
    np.testing.assert_allclose(sk.view, view, atol=1e-12)
    np.testing.assert_allclose(sk.closer, closer, atol=1e-12)
    np.testing.assert_allclose(ex.ctl.waypoints, [view, closer], atol=1e-12)

    ax = plots_ch07.plot_return_rule(sketch=sk)
    assert ax.yaxis_inverted()                       # seen from above, y down
    np.testing.assert_allclose(_by_gid(ax, "anchor").get_xydata(), [a])
    # the landmarks are the filter's estimates: drawn as the course's mapped landmarks (blue +),
    # not as black stars (true markers)
    marks = _by_gid(ax, "landmarks")
    assert marks.get_marker() == "+" and marks.get_color() == "tab:blue"
    np.testing.assert_allclose(marks.get_xydata(), [p for p, _, _ in sk.landmarks.values()])
    assert not [ln for ln in ax.get_lines() if ln.get_marker() == "*"]
    assert any("landmark" in t.get_text() for t in ax.texts if "too uncertain" in t.get_text())
    np.testing.assert_allclose(_by_gid(ax, "view").get_xydata(), [view])
    np.testing.assert_allclose(_by_gid(ax, "closer").get_xydata(), [closer])
    np.testing.assert_allclose(_by_gid(ax, "return_distance").get_xydata(), [a, view])
    np.testing.assert_allclose(_by_gid(ax, "path").get_xydata(), [sk.pose[:2], view, closer])
    circle = _by_gid(ax, "sigma_xy")
    np.testing.assert_allclose(circle.center, sk.pose[:2])
    assert abs(circle.radius - sk.sigma_xy) < 1e-12
    rays = _by_gid(ax, "sightings").get_xydata().reshape(-1, 3, 2)
    assert rays.shape[0] == len(sk.sightings[1])
    np.testing.assert_allclose(rays[:, 0], np.tile(a, (rays.shape[0], 1)))
    np.testing.assert_allclose(rays[:, 1] - a, 0.7 * sk.sightings[1])
    plt.close(ax.figure)


def test_a_cut_off_return_is_found_and_drawn_apart():
    pol = SimpleNamespace(mode="return", anchor=7, returns=[(1.0, 2.0, 3, 0.2, 0.05)],
                          goals=[(0.5, 1.0, 1.0, "explore"), (1.0, 0.0, 0.0, "return"),
                                 (2.0, 2.0, 2.0, "explore"), (3.5, 0.0, 1.0, "return")],
                          sigma_return=0.1)
    assert plots_ch07.unfinished_return(pol) == (3.5, 7)
    assert plots_ch07.unfinished_return(SimpleNamespace(**{**vars(pol), "mode": "explore"})) is None
    t = np.linspace(0.0, 4.0, 9)
    x = np.column_stack([t, -t, 0 * t])
    trace = SimpleNamespace(t=t, x=x, truth=x, P=np.tile(np.eye(3) * 1e-4, (t.size, 1, 1)),
                            error=np.zeros_like(x), kind=np.array(["predict"] * t.size),
                            filter=SimpleNamespace(landmarks={}))
    hist = {"t": t, "coverage": t / 8, "landmarks": np.ones(t.size), "sigma_xy": 0.1 + 0 * t,
            "mode": ["explore"] * t.size, "error_xy": 0 * t}
    exp = SimpleNamespace(policy=pol, trace=trace, history=lambda: hist)
    fig, axes = plots_ch07.plot_exploration_history(exp)
    for ax in axes:
        band = _by_gid(ax, "cut_off")
        assert (band.get_x(), band.get_x() + band.get_width()) == (3.5, 4.0)
    plt.close(fig)
    # on the map: the estimate from the cut-off return's start to the end, under a band
    fig, ax = plt.subplots()
    plots_ch07.plot_exploration(ax, SimpleNamespace(policy=pol, trace=trace))
    np.testing.assert_allclose(_by_gid(ax, "cut_off").get_xydata(), x[t >= 3.5, :2])
    plt.close(fig)
