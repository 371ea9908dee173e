#!/usr/bin/env python3
"""Render magopt particle snapshots with OVITO (the pictures in docs/pictures/).

Optional tooling: magopt neither needs nor calls this script; it shows that magopt's
particle files open in a real viewer, with radii and colour columns read from the files.

Install (user space, no root):

    python3 -m venv /tmp/viewers-venv
    /tmp/viewers-venv/bin/pip install ovito pillow        # ovito 3.17.2 was used

OVITO's renderers (OpenGL and Tachyon alike) go through Vulkan. On a machine without a GPU
driver, a software driver does (Debian/Ubuntu, no root needed: unpack the packages into a
folder and point the Vulkan loader at it):

    mkdir -p /tmp/vkdeb && cd /tmp/vkdeb
    apt-get download libvulkan1 mesa-vulkan-drivers
    for d in *.deb; do dpkg-deb -x "$d" root; done
    sed "s#/usr/lib/#$PWD/root/usr/lib/#" \
        root/usr/share/vulkan/icd.d/lvp_icd.x86_64.json > lvp.json
    export LD_LIBRARY_PATH=$PWD/root/usr/lib/x86_64-linux-gnu VK_ICD_FILENAMES=$PWD/lvp.json

(or, with root: apt install libvulkan1 mesa-vulkan-drivers).

The runs whose outputs it renders:

    magopt align --particles 1000 --out ALIGN --snapshot-times 10,20,30
    magopt bed --preset bidisperse --particles 400 --mixing-ratio 0.4 --out BED

Then:

    python3 scripts/render-snapshots.py ALIGN BED docs/pictures

writes docs/pictures/align-cos-theta.png (the align frame nearest t = 20 s, mid-alignment,
coloured by cos_theta = |n·z|) and docs/pictures/bed-max-compression.png (the bed at
maximum compression seen from +z, coloured by force_magnitude). Each image is about
800 px wide and is reduced to a 256-colour palette to stay small (Pillow).
"""

import glob
import os
import re
import sys

from ovito.io import import_file  # noqa: I001 (ovito before PySide6)
from ovito.modifiers import ColorCodingModifier
from ovito.vis import ColorLegendOverlay, TachyonRenderer, TextLabelOverlay, Viewport
from PySide6.QtCore import Qt  # installed with ovito


def frame_time(path):
    """The Time= value of an extended XYZ frame's comment line, s."""
    with open(path) as f:
        f.readline()
        return float(re.search(r"Time=(\S+)", f.readline()).group(1))


def shrink(path):
    """Reduce a PNG to a 256-colour palette (keeps it well under 200 kB)."""
    try:
        from PIL import Image
    except ImportError:
        return
    Image.open(path).convert("RGB").quantize(colors=256, dither=Image.Dither.NONE).save(
        path, optimize=True
    )


def render(pipeline, viewport, path, legend, title, size):
    pipeline.add_to_scene()
    viewport.zoom_all(size)
    viewport.overlays.append(legend)
    viewport.overlays.append(
        TextLabelOverlay(text=title, alignment=0x0020 | 0x0001, font_size=0.035,
                         text_color=(0, 0, 0), offset_x=0.01, offset_y=-0.01)
    )
    viewport.render_image(size=size, filename=path, background=(1, 1, 1),
                          renderer=TachyonRenderer(ambient_occlusion=True, antialiasing_samples=4))
    pipeline.remove_from_scene()
    shrink(path)
    print(f"wrote {path} ({os.path.getsize(path) // 1024} kB)")


def align_picture(align_dir, out):
    frames = sorted(glob.glob(os.path.join(align_dir, "snapshots", "frame.*.xyz")))
    if not frames:
        frames = [os.path.join(align_dir, "snapshots", "end.xyz")]
    path = min(frames, key=lambda f: abs(frame_time(f) - 20.0))
    t = frame_time(path)
    pipeline = import_file(path)  # radius column -> Radius, cos_theta -> 1-component property
    coding = ColorCodingModifier(property="cos_theta", start_value=0.0, end_value=1.0,
                                 gradient=ColorCodingModifier.Viridis())
    pipeline.modifiers.append(coding)
    n = pipeline.compute().particles.count
    vp = Viewport(type=Viewport.Type.Perspective, camera_dir=(-1, -0.8, -0.55))
    legend = ColorLegendOverlay(modifier=coding, title="cos θ = |n·z|", alignment=0x0002 | 0x0080,
                                orientation=Qt.Orientation.Vertical,
                                font_size=0.07, text_color=(0, 0, 0), legend_size=0.5,
                                format_string="%.1f", offset_x=-0.02)
    title = f"magopt align: {n} particles, t = {t:.1f} s ({os.path.basename(path)})"
    render(pipeline, vp, os.path.join(out, "align-cos-theta.png"), legend, title, (800, 600))


def bed_picture(bed_dir, out):
    path = os.path.join(bed_dir, "snapshots", "max-compression.dump")
    pipeline = import_file(path)  # LAMMPS dump: radius -> Radius, type -> Particle Type
    coding = ColorCodingModifier(property="force_magnitude",
                                 gradient=ColorCodingModifier.Magma())
    pipeline.modifiers.append(coding)
    data = pipeline.compute()
    vp = Viewport(type=Viewport.Type.Top)
    legend = ColorLegendOverlay(modifier=coding, title="force magnitude |F| (N)",
                                alignment=0x0004 | 0x0040, font_size=0.12, text_color=(0, 0, 0),
                                legend_size=0.45, format_string="%.3f", offset_y=0.04)
    title = (f"magopt bed: {data.particles.count} discs at maximum compression, "
             f"t = {data.attributes['Time']:.2f} s")
    render(pipeline, vp, os.path.join(out, "bed-max-compression.png"), legend, title, (800, 320))


def main():
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    align_dir, bed_dir, out = sys.argv[1:]
    os.makedirs(out, exist_ok=True)
    align_picture(align_dir, out)
    bed_picture(bed_dir, out)


if __name__ == "__main__":
    main()
