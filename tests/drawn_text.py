"""The text a matplotlib figure draws, as drawn: every string the renderer is asked to draw, with
its extent in pixels (tick labels that the axes hold but do not show are left out, as they are not
drawn), for tests that nothing falls outside the figure."""

from __future__ import annotations


def drawn_text(fig) -> list[tuple[str, object]]:
    """The (text, window extent) of every text artist drawing ``fig`` draws with the Agg renderer."""
    fig.canvas.draw()  # the layout, where an engine makes it
    renderer = fig.canvas.get_renderer()
    drawn = []
    draw_text = renderer.draw_text

    def record(gc, x, y, s, prop, angle, ismath=False, mtext=None):
        if mtext is not None and s.strip():
            drawn.append(mtext)
        return draw_text(gc, x, y, s, prop, angle, ismath, mtext)

    renderer.draw_text = record
    try:
        fig.draw(renderer)
    finally:
        del renderer.draw_text
    return [(text.get_text(), text.get_window_extent(renderer)) for text in drawn]


def outside(fig) -> list[str]:
    """The texts of ``fig`` that reach beyond its edges, each with its extent and the figure's size."""
    width, height = fig.bbox.width, fig.bbox.height
    assert width > 0 and height > 0
    return [f"{text!r} at {extent.bounds} in {width:g} x {height:g}" for text, extent in drawn_text(fig)
            if extent.x0 < 0 or extent.y0 < 0 or extent.x1 > width or extent.y1 > height]
