"""interact_figure: the default figure is an ordinary output, a change redraws it in place."""

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

ipywidgets = pytest.importorskip("ipywidgets")
from IPython.core.interactiveshell import InteractiveShell  # noqa: E402
from IPython.utils.capture import capture_output  # noqa: E402

from slamlib.course.widgets import interact_figure, render_outputs  # noqa: E402


@pytest.fixture(scope="module")
def shell():
    return InteractiveShell.instance()


def _plot(slope=1.0, label="a"):
    fig, ax = plt.subplots(figsize=(2, 2), dpi=50)
    ax.plot([0, 1], [0, slope])
    print(f"slope {slope:.1f} {label}")


def test_render_outputs_returns_text_and_png():
    text, pngs = render_outputs(_plot, {"slope": 2.0, "label": "b"})
    assert text == "slope 2.0 b\n"
    assert len(pngs) == 1 and pngs[0][:8] == b"\x89PNG\r\n\x1a\n"
    assert plt.get_fignums() == []          # the figure it drew is closed


def test_default_figure_is_an_output_and_changes_update_it(shell):
    slider = ipywidgets.FloatSlider(value=1.0, min=0.0, max=3.0, continuous_update=False)
    with capture_output() as cap:
        box = interact_figure(_plot, slope=slider, label=ipywidgets.Dropdown(options=["a", "c"]))
    first = cap.outputs
    # a text line, the default figure (a PNG with a display id), then the controls
    assert first[0].data["text/plain"] == "slope 1.0 a"
    png0 = first[1].data["image/png"]
    assert png0[:8] == b"\x89PNG\r\n\x1a\n"
    ids = [o.transient.get("display_id") for o in first[:2]]
    assert all(ids) and ids[0] != ids[1]
    assert "application/vnd.jupyter.widget-view+json" in first[2].data
    assert slider.description == "slope"
    with capture_output() as cap2:
        slider.value = 2.5
    upd = cap2.outputs
    assert [o.update for o in upd] == [True, True]
    assert [o.transient["display_id"] for o in upd] == ids
    assert upd[0].data["text/plain"] == "slope 2.5 a"
    assert upd[1].data["image/png"] != png0      # redrawn with the new slope
    box.close()


def test_controls_are_checked():
    with pytest.raises(ValueError, match="controls"):
        interact_figure(_plot)
    with pytest.raises(ValueError, match=r"controls\['slope'\]"):
        interact_figure(_plot, slope=np.float64(1.0))
