"""How the rater pages draw an item: crops as large as the window allows, one button row.

Layer: annotate (rating study).

Thin Streamlit view helpers shared by the binary and the pairwise rater pages of
:mod:`annotate.app`; no study logic here.

- :func:`page_style`: the page's CSS and script (once per run): little padding, each crop
  drawn as wide as its share of the row and at most as tall as the window minus the rows
  above and below it, so the whole item and its buttons fit on screen; the crops of an item
  share one size (square crops, equal shares), hence one scale. Good and Bad are coloured
  apart with a colour-blind-safe pair (Okabe-Ito blue and vermillion) and keep their
  letters. The arrow keys press a pairwise item's side buttons. On a phone (at most 640 px
  wide) a pairwise item shows its reference on top and the two choices side by side under
  it, all three at one size, and its answer buttons sit in a bar at the bottom of the screen.
- :func:`pair_view`: the titled crops side by side (container key ``pair``: one image
  element, so a vote redraws few elements; the CSS lays its crops out in a row with their
  titles above) and the scale line, e.g. "All images at the same scale: ×3.2 (shown px per
  camera px)". The scale is the drawn width over the object's square side in the camera
  image (``crop_side``, px): the server writes it for the stored crop size and the page's
  script keeps it equal to the size the browser actually draws. Nothing in it names the
  item.

>>> f"{scale_text(640, 200)}"
'×3.2'
>>> f"{scale_text(320, 640)}"
'×0.5'
"""

from __future__ import annotations

import math

import streamlit as st

__all__ = ["page_style", "pair_view", "scale_text", "GOOD_COLOUR", "BAD_COLOUR", "ROWS_PX"]

#: Okabe-Ito blue and vermillion: apart for every common colour-vision deficiency
GOOD_COLOUR, BAD_COLOUR = "#0072B2", "#D55E00"
#: vertical room (px) the rows around the crops take: padding, progress, titles, scale, buttons
ROWS_PX = 250
#: on a phone, the vertical room (px) a pairwise item's rows take besides its two rows of
#: crops (reference, then the choices, all at one size): progress, titles, scale, button bar
PHONE_ROWS_PX = 340

_CSS = f"""<style>
[data-testid="stMainBlockContainer"] {{ padding: 2.5rem 1.5rem 1rem; max-width: none; }}
.st-key-pair [data-testid="stFullScreenFrame"] > div {{ width: 100%; }}
.st-key-pair [data-testid="stImage"] {{ display: flex; flex-flow: row nowrap; gap: 1rem;
  justify-content: center; width: 100%; }}
.st-key-pair [data-testid="stImageContainer"] {{ flex: 1 1 0; min-width: 0; display: flex;
  flex-direction: column-reverse; align-items: center; }}
.st-key-pair [data-testid="stImage"] img {{
  width: min(100%, calc(100vh - {ROWS_PX}px)) !important; height: auto !important; }}
.st-key-pair [data-testid="stImageCaption"] {{ width: 100% !important; margin: 0 0 0.25rem; }}
.st-key-pair [data-testid="stCaptionContainer"] {{ color: inherit; }}
.st-key-pair [data-testid="stImageCaption"] p {{ text-align: center; margin: 0; font-weight: 600;
  font-size: 1rem; color: inherit; }}
.st-key-pair [data-testid="stElementToolbar"] {{ display: none; }}
.nvrq-scale {{ text-align: center; color: #555; font-size: 0.9rem; }}
[class*="st-key-vote_good-"] button {{ background: {GOOD_COLOUR}; border-color: {GOOD_COLOUR};
  color: #fff; }}
[class*="st-key-vote_bad-"] button {{ background: {BAD_COLOUR}; border-color: {BAD_COLOUR};
  color: #fff; }}
[class*="st-key-vote_"] button {{ min-width: 9rem; }}
@media (max-width: 640px) {{  /* a phone: the pair stays side by side, the buttons in view */
  [data-testid="stMainBlockContainer"] {{ padding: 1rem 0.5rem 0.5rem; }}
  .st-key-pair [data-testid="stImage"] {{ gap: 0.5rem; }}
  [class*="st-key-vote_"] button {{ min-width: 5.5rem; }}
  [class*="st-key-undo-"] button {{ min-width: 4rem; }}
  /* a pairwise item: the reference on top, the two choices side by side under it, the
     answer buttons in a bar at the bottom of the screen, where a thumb reaches */
  .st-key-pair [data-testid="stImage"]:has(> :nth-child(3)) {{ flex-wrap: wrap; row-gap: 0.75rem; }}
  .st-key-pair [data-testid="stImage"]:has(> :nth-child(3)) > :nth-child(2) {{ order: -1; flex: 0 0 100%; }}
  .st-key-pair [data-testid="stImage"]:has(> :nth-child(3)) img {{
    width: min(100%, calc(50vh - {PHONE_ROWS_PX // 2}px)) !important; }}
  .st-key-pair [data-testid="stImage"]:has(> :nth-child(3)) > :nth-child(2) img {{
    width: min(calc((100% - 0.5rem) / 2), calc(50vh - {PHONE_ROWS_PX // 2}px)) !important; }}
  .st-key-vote_row:has([class*="st-key-vote_tie-"]) {{ position: fixed; left: 0; right: 0; bottom: 0;
    z-index: 100; background: #fff; border-top: 1px solid #ddd; padding: 0.5rem; gap: 0.5rem;
    flex-wrap: wrap; box-sizing: border-box; }}
  .st-key-vote_row:has([class*="st-key-vote_tie-"]) > div {{ margin: 0; }}
  .st-key-vote_row [class*="st-key-vote_left-"] {{ order: 1; flex: 1 1 40%; }}
  .st-key-vote_row [class*="st-key-vote_right-"] {{ order: 2; flex: 1 1 40%; }}
  .st-key-vote_row [class*="st-key-vote_tie-"] {{ order: 3; flex: 1 1 40%; }}
  .st-key-vote_row:has([class*="st-key-vote_tie-"]) [class*="st-key-undo-"] {{ order: 4; flex: 1 1 40%; }}
  .st-key-vote_row:has([class*="st-key-vote_tie-"]) button {{ width: 100%; min-height: 3rem; }}
  [data-testid="stMainBlockContainer"]:has([class*="st-key-vote_tie-"]) {{ padding-bottom: 9rem; }}
}}
</style>"""

# Keeps every scale line equal to the width the browser draws the first crop at (the line's
# data-side is the object's side in camera pixels), and makes the arrow keys press a pairwise
# item's side buttons (a Streamlit button takes one shortcut: 1 and 2 are theirs); installed
# once per page, it serves every item the voting panel draws after it.
_PAGE_JS = """<script>
(() => {
  if (window.__nvrqScale) return;
  const update = () => {
    const img = document.querySelector('.st-key-pair [data-testid="stImage"] img');
    for (const el of document.querySelectorAll('.nvrq-scale')) {
      const side = parseFloat(el.dataset.side), b = el.querySelector('b');
      if (!img || !img.naturalWidth || !(side > 0) || !b) continue;
      const w = img.getBoundingClientRect().width / side;
      const text = '\u00d7' + (w < 9.95 ? w.toFixed(1) : w.toFixed(0));
      if (b.textContent !== text) b.textContent = text;
    }
  };
  window.__nvrqScale = setInterval(update, 200);
  window.addEventListener('resize', update);
  document.addEventListener('keydown', (e) => {
    const side = {ArrowLeft: 'left', ArrowRight: 'right'}[e.key], t = e.target;
    if (!side || e.repeat || e.altKey || e.ctrlKey || e.metaKey || e.shiftKey) return;
    if (t && (t.isContentEditable || /^(INPUT|TEXTAREA|SELECT)$/.test(t.tagName))) return;
    const live = [...document.querySelectorAll(`[class*="st-key-vote_${side}-"] button`)]
      .filter((b) => !b.disabled && !b.closest('[data-stale="true"]'));
    if (live.length !== 1) return;  // no item on screen, or one being replaced
    e.preventDefault();
    live[0].click();
  });
})();
</script>"""


def scale_text(drawn_px: float, side_px: float) -> str:
    """``'×S'``: drawn pixels per camera pixel, one decimal below 10 (the script's rule).

    Parameters
    ----------
    drawn_px : float
        Display pixels the object's square is drawn on.
    side_px : float
        Its side in camera pixels.

    Returns
    -------
    str
    """
    s = float(drawn_px) / float(side_px)
    return f"×{s:.1f}" if s < 9.95 else f"×{s:.0f}"


def page_style() -> None:
    """The rater page's CSS and its script (scale lines, arrow keys); once per run, before
    the voting panel."""
    st.html(_CSS)
    st.html(_PAGE_JS, unsafe_allow_javascript=True)


def pair_view(titles, images, *, crop_side: float | None, display_size: int, token: str) -> None:
    """``images`` (encoded crops, all ``display_size`` px square) under ``titles``, side by side.

    ``crop_side``: the object's square side in camera pixels (None or NaN: an old study
    without it, no scale line). ``token``: the opaque token of the item on screen, so the
    scale line is redrawn for every item.

    Parameters
    ----------
    titles : sequence of str
        One caption per image.
    images : sequence of bytes
        Encoded crops.
    crop_side : float or None
        The object's square side, camera pixels.
    display_size : int
        Side of each crop on screen, pixels.
    token : str
        The opaque token of the item on screen.
    """
    with st.container(key="pair"):  # one element: its crops side by side, titled (CSS above)
        # the crops' own format (one per study): "auto" would re-encode PNG as JPEG (lossy)
        jpeg = all(image[:2] == b"\xff\xd8" for image in images)
        st.image(list(images), caption=[f"**{title}**" for title in titles], width="stretch",
                 output_format="JPEG" if jpeg else "PNG")
    if crop_side is None or not math.isfinite(float(crop_side)) or float(crop_side) <= 0:
        return
    side = float(crop_side)
    st.html(f'<div class="nvrq-scale" data-side="{side:g}" data-item="{token}">All images at the '
            f"same scale: <b>{scale_text(display_size, side)}</b> (shown pixels per camera pixel)"
            "</div>")
