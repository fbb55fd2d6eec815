"""The picture on the sheet: a map-like page drawn procedurally from a seed (nothing downloaded),
or the person's own picture (:func:`person_page`: ``--set picture.image=FILE``).

:func:`map_texture` paints, with OpenCV, on paper-coloured ground: coloured areas (parks,
lakes, fields as filled polygons), a road network (thick polylines with dark edges), blocks of
houses (small rectangles), symbols (circles, triangles, crosses) and rows of text-like letters.
It is made to have what a feature detector finds -- corners and blobs at many scales, all over
the page -- as a real map or printed page has.  The same seed gives the same image.
"""

from __future__ import annotations

import numpy as np

from ...core.errors import InputError
from ...core.images import read_picture as read

#: the texture's resolution, pixels per metre (as :data:`hila_lang.sim.canvas.PIXELS_PER_METRE`)
PIXELS_PER_METRE = 2000.0
_AREA_RGB = ((170, 215, 150), (150, 190, 230), (230, 210, 150), (215, 180, 200), (190, 200, 160))


def map_texture(size: tuple[float, float], seed: int) -> np.ndarray:
    """An RGB uint8 image (H, W, 3) of a map-like page ``size`` = (across, depth) metres."""
    # lazy: loads cv2, which importing this module does not
    import cv2

    rng = np.random.default_rng([int(seed), 24])
    w = int(round(size[0] * PIXELS_PER_METRE))
    h = int(round(size[1] * PIXELS_PER_METRE))
    img = np.empty((h, w, 3), np.uint8)
    img[:] = (244, 240, 228)

    def pt():
        return int(rng.uniform(0, w)), int(rng.uniform(0, h))

    for _ in range(14):  # areas
        c = np.array(pt())
        n = int(rng.integers(5, 9))
        ang = np.sort(rng.uniform(0, 2 * np.pi, n))
        rad = rng.uniform(0.03, 0.12) * w * rng.uniform(0.6, 1.0, n)
        poly = (c + np.column_stack([np.cos(ang), np.sin(ang)]) * rad[:, None]).astype(np.int32)
        cv2.fillPoly(img, [poly], _AREA_RGB[int(rng.integers(len(_AREA_RGB)))])
    for _ in range(60):  # houses
        x, y = pt()
        s = int(rng.integers(5, 14))
        cv2.rectangle(img, (x, y), (x + s, y + int(s * rng.uniform(0.6, 1.5))),
                      tuple(int(v) for v in rng.integers(60, 200, 3)), -1)
    for _ in range(9):  # roads
        pts = np.array([pt() for _ in range(4)], dtype=np.int32)
        width = int(rng.integers(4, 9))
        cv2.polylines(img, [pts], False, (90, 80, 70), width + 3, cv2.LINE_AA)
        cv2.polylines(img, [pts], False, tuple(int(v) for v in rng.choice([(250, 250, 250), (250, 200, 90)])),
                      width, cv2.LINE_AA)
    for _ in range(40):  # symbols
        x, y = pt()
        s = int(rng.integers(4, 10))
        colour = tuple(int(v) for v in rng.integers(0, 160, 3))
        kind = int(rng.integers(3))
        if kind == 0:
            cv2.circle(img, (x, y), s, colour, 2, cv2.LINE_AA)
        elif kind == 1:
            tri = np.array([[x, y - s], [x - s, y + s], [x + s, y + s]], np.int32)
            cv2.fillPoly(img, [tri], colour, cv2.LINE_AA)
        else:
            cv2.line(img, (x - s, y - s), (x + s, y + s), colour, 2, cv2.LINE_AA)
            cv2.line(img, (x - s, y + s), (x + s, y - s), colour, 2, cv2.LINE_AA)
    letters = "ABCDEFGHJKLMNPRSTUVWXYZ0123456789"
    for _ in range(16):  # names
        x, y = pt()
        text = "".join(letters[i] for i in rng.integers(len(letters), size=int(rng.integers(3, 8))))
        cv2.putText(img, text, (x, y), cv2.FONT_HERSHEY_SIMPLEX, float(rng.uniform(0.35, 0.7)), (30, 30, 40),
                    int(rng.integers(1, 3)), cv2.LINE_AA)
    cv2.rectangle(img, (0, 0), (w - 1, h - 1), (40, 40, 40), 3)
    return img


#: the paper around a person's picture that does not fill the page (RGB)
PAPER_RGB = (244, 240, 228)


def read_picture(path) -> np.ndarray:
    """A person's picture file as RGB uint8 (H, W, 3) (:func:`hila_lang.core.images.read_picture`:
    its size checked by its header before it is decoded); an :class:`InputError` naming the file
    when it is missing, too large, not a picture or smaller than 16 pixels a side."""
    image = read(path)
    if min(image.shape[:2]) < 16:
        raise InputError("a picture of 16 pixels or more a side is needed to find features on", file=str(path))
    return np.ascontiguousarray(image[:, :, ::-1])


def person_page(size: tuple[float, float], picture: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A person's ``picture`` printed on a page ``size`` = (across, depth) metres: scaled to fit
    it whole, its shape kept, centred on paper.  Returns the page (H, W, 3) and ``to_uv``
    (3, 3): the map from the picture's pixels (u right, v down, homogeneous) to the page's
    texture coordinates (0..1, v down), so a route drawn on the picture lands on the page."""
    # lazy: loads cv2, which importing this module does not
    import cv2

    w = int(round(size[0] * PIXELS_PER_METRE))
    h = int(round(size[1] * PIXELS_PER_METRE))
    ph, pw = picture.shape[:2]
    scale = min(w / pw, h / ph)
    sw, sh = max(1, int(round(pw * scale))), max(1, int(round(ph * scale)))
    page = np.empty((h, w, 3), np.uint8)
    page[:] = PAPER_RGB
    x0, y0 = (w - sw) // 2, (h - sh) // 2
    page[y0:y0 + sh, x0:x0 + sw] = cv2.resize(picture, (sw, sh), interpolation=cv2.INTER_AREA)
    to_uv = np.array([[sw / pw / w, 0.0, x0 / w], [0.0, sh / ph / h, y0 / h], [0.0, 0.0, 1.0]])
    return page, to_uv
