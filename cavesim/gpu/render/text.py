"""A line of text drawn over a window's picture (the preview's help line): the glyphs are
rasterized once on the CPU with Pillow's built-in font into a one-channel texture, and
drawn as a blended quad after the picture. Only the window gets it: the walls' pictures,
their PNGs and the goldens never do."""

from __future__ import annotations

import moderngl
import numpy as np
from PIL import Image, ImageDraw, ImageFont

from cavesim.gpu.render.programs import OVERLAY

FONT_PIXELS = 13
MARGIN = 3  # pixels of band around the text


class TextLine:
    def __init__(self, ctx: moderngl.Context, text: str) -> None:
        font = ImageFont.load_default(FONT_PIXELS)
        left, top, right, bottom = font.getbbox(text)
        image = Image.new("L", (right - left + 2 * MARGIN, bottom - top + 2 * MARGIN))
        ImageDraw.Draw(image).text((MARGIN - left, MARGIN - top), text, fill=255, font=font)
        self.ctx = ctx
        self.texture = ctx.texture(image.size, 1, np.asarray(image).tobytes())
        self.texture.filter = (moderngl.NEAREST, moderngl.NEAREST)  # one texel, one pixel
        self.program = OVERLAY.build(ctx, {})
        self.quad = ctx.vertex_array(self.program, [])

    @property
    def size(self) -> tuple[int, int]:
        return self.texture.size

    def draw(self, window: tuple[int, int], at: tuple[int, int] = (0, 0)) -> None:
        """Blend the line into the bound framebuffer of `window` pixels, its lower left
        corner `at` pixels from the lower left (clipped at the window's edge)."""
        (width, height), (x, y) = window, at
        w, h = self.size
        self.program["rect"].value = (2 * x / width - 1, 2 * y / height - 1,
                                      2 * (x + w) / width - 1, 2 * (y + h) / height - 1)
        self.texture.use(0)
        self.program["glyphs"].value = 0
        self.ctx.enable(moderngl.BLEND)
        self.ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
        self.quad.render(moderngl.TRIANGLE_STRIP, vertices=4)
        self.ctx.disable(moderngl.BLEND)
        self.ctx.blend_func = moderngl.DEFAULT_BLENDING
