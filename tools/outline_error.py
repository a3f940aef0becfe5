#!/usr/bin/python3
"""How an avatar's outline differs from the truth on a split of its dataset:
per image, the rendered opacity against the dataset's mask (areas in pixels,
the opacity the mask lacks and the mask the opacity lacks), the share of
the squared colour error within 2 pixels of the mask's outline, and the PSNR
there and inside the mask farther than 2 pixels from it (the interior:
colour and shading, apart from where the outline lies); over all images, the
rendered area against the masks' and the share of the squared error on the
pixels where the outline is misplaced (opacity and mask differ by over 0.25),
the opacity outside the mask and the mask without opacity per image, and how
far the truth's colour just inside the outline lies from the background (what
a misplaced outline costs per pixel);
and the subject-box PSNR (`avatar eval`'s) split into what the outline and
what the colour cost: the render, the render's colour over the truth's
coverage (the mask), and the truth's colour over the render's coverage. The
colours are the pictures' own, un-composited from the background by the
opacity or the mask where it exceeds 0.05.

    PYTHONPATH=build/python /usr/bin/python3 tools/outline_error.py RUN [--split novel_pose] [--data DIR]
        [--picture sheet.png --images 0,3]

With --picture, a PNG of the listed images, each cropped to its mask's box and
shown 3 times larger: the truth, the render, and the outline (red: opacity
where the mask is empty; blue: mask without opacity; grey: the mask).

Any avatar run (volume or Gaussians) that `fskin avatar eval` takes.
"""
import argparse
import json
import pathlib

import numpy as np
import torch

import fskin


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run")
    parser.add_argument("--split", default="novel_pose", choices=("train", "novel_view", "novel_pose"))
    parser.add_argument("--data", default="", help="image dataset (default: the run's)")
    parser.add_argument("--picture", default="", help="write the listed images' sheet to this PNG")
    parser.add_argument("--images", default="0", help="images of the sheet, comma-separated indices")
    args = parser.parse_args()
    sheet_images = [int(index) for index in args.images.split(",")] if args.picture else []
    sheet_rows = []
    run = pathlib.Path(args.run)
    data = args.data
    if not data:
        config = run / "gaussian_avatar.json"
        if not config.exists():
            config = run / "avatar.json"
        data = json.loads(config.read_text())["data"]["path"]
    split = pathlib.Path(data) / args.split
    poses = np.load(split / "poses.npz")
    cameras = np.load(split / "cameras.npz")
    width, height = int(cameras["width"]), int(cameras["height"])
    background = torch.tensor(json.loads((pathlib.Path(data) / "manifest.json").read_text())["background"],
                              dtype=torch.float32)
    box_psnr = {"render": [], "true coverage": [], "true colour": []}
    band_error = total_error = interior_error = misplaced_error = 0.0
    band_pixels = interior_pixels = misplaced_pixels = 0
    rendered_total = mask_total = outside_total = missing_total = contrast_total = 0.0
    outline_pixels = 0
    print("image  rendered area  mask area  ratio  opacity outside the mask  mask without opacity")
    for i in range(len(poses["bone_transforms"])):
        truth = fskin.read_png(str(split / "images" / f"image_{i:04d}.png")).float() / 255
        mask = fskin.read_png(str(split / "masks" / f"mask_{i:04d}.png"))[..., 0].float() / 255
        rgb, alpha = fskin.render_avatar(str(run), torch.from_numpy(poses["bone_transforms"][i]),
                                         torch.from_numpy(cameras["intrinsic"][i]),
                                         torch.from_numpy(cameras["extrinsic"][i]), width, height)
        inside = (mask > 0.5).float()[None, None]
        grown = torch.nn.functional.max_pool2d(inside, 5, 1, 2)[0, 0] > 0
        shrunk = -torch.nn.functional.max_pool2d(-inside, 5, 1, 2)[0, 0] > 0
        error = (rgb - truth).square().sum(-1)
        band = grown & ~shrunk
        band_error += float(error[band].sum())
        band_pixels += int(band.sum())
        interior_error += float(error[shrunk].sum())
        interior_pixels += int(shrunk.sum())
        total_error += float(error.sum())
        misplaced = (alpha - mask).abs() > 0.25
        misplaced_error += float(error[misplaced].sum())
        misplaced_pixels += int(misplaced.sum())
        for name, picture in split_by_cause(truth, rgb, alpha, mask, background).items():
            box_psnr[name].append(picture_psnr(picture, truth, mask_box(mask)))
        if i in sheet_images:
            sheet_rows.append(sheet_row(truth, rgb, alpha, mask))
        rendered, truth_area = float(alpha.sum()), float(mask.sum())
        outside, missing = float((alpha - mask).clamp(min=0).sum()), float((mask - alpha).clamp(min=0).sum())
        rendered_total += rendered
        mask_total += truth_area
        outside_total += outside
        missing_total += missing
        # The truth against the background on the mask's pixels next to an empty one:
        # what a misplaced outline costs per pixel.
        outline = (mask > 0.5) & (torch.nn.functional.max_pool2d((mask <= 0.5).float()[None, None], 3, 1, 1)[0, 0] > 0)
        contrast_total += float((truth - background).square().sum(-1)[outline].sum())
        outline_pixels += int(outline.sum())
        print(f"{i:5d}  {rendered:13.0f}  {truth_area:9.0f}  {rendered / truth_area:5.3f}  "
              f"{outside:24.0f}  {missing:20.0f}")
    print(f"all images: rendered area / mask area {rendered_total / mask_total:.4f}; "
          f"{misplaced_pixels} pixels where opacity and mask differ by over 0.25 hold "
          f"{100 * misplaced_error / total_error:.1f} % of the squared colour error")
    images = len(poses["bone_transforms"])
    print(f"per image: opacity outside the mask {outside_total / images:.1f}, mask without opacity "
          f"{missing_total / images:.1f}; the truth against the background just inside the outline: "
          f"mean squared difference {contrast_total / max(outline_pixels, 1):.3f} (sum over RGB)")
    print(f"squared colour error within 2 pixels of the outline: {100 * band_error / total_error:.1f} %")
    if args.picture:
        if len(sheet_rows) != len(sheet_images):
            raise SystemExit(f"--images {args.images}: the split has {len(poses['bone_transforms'])} images")
        fskin.write_png(args.picture, (stack_rows(sheet_rows) * 255).round().to(torch.uint8))
        print(f"wrote {args.picture}")
    psnr = lambda error, pixels: -10 * np.log10(max(error / max(3 * pixels, 1), 1e-12))
    print(f"PSNR within 2 pixels of the outline: {psnr(band_error, band_pixels):.2f} dB; "
          f"inside, farther from it: {psnr(interior_error, interior_pixels):.2f} dB")
    print("subject-box PSNR: " + "; ".join(f"{name} {np.mean(values):.2f} dB" for name, values in box_psnr.items()))


def split_by_cause(truth, rgb, alpha, mask, background):
    """The render, and two pictures that each keep one of its errors: its colour
    over the mask's coverage, and the truth's colour over its coverage."""
    def colour(picture, coverage):
        c = coverage[..., None]
        return torch.where(c > 0.05, (picture - (1 - c) * background) / c.clamp(min=1e-3), background)
    m, a = mask[..., None], alpha[..., None]
    return {"render": rgb,
            "true coverage": colour(rgb, alpha) * m + (1 - m) * background,
            "true colour": colour(truth, mask) * a + (1 - a) * background}


def mask_box(mask, grow=0.1):
    """avatar eval's subject box (radiance/image_dataset.h, mask_box): the mask's
    box grown by a tenth of its size, as (v0, v1, u0, u1)."""
    rows, columns = torch.nonzero(mask > 0, as_tuple=True)
    if len(rows) == 0:
        return 0, mask.shape[0], 0, mask.shape[1]
    v0, v1, u0, u1 = int(rows.min()), int(rows.max()) + 1, int(columns.min()), int(columns.max()) + 1
    gv, gu = int(np.ceil(0.5 * grow * (v1 - v0))), int(np.ceil(0.5 * grow * (u1 - u0)))
    return max(0, v0 - gv), min(mask.shape[0], v1 + gv), max(0, u0 - gu), min(mask.shape[1], u1 + gu)


def picture_psnr(picture, truth, box):
    v0, v1, u0, u1 = box
    error = float((picture.clamp(0, 1) - truth)[v0:v1, u0:u1].square().mean())
    return -10 * np.log10(max(error, 1e-12))


def sheet_row(truth, rgb, alpha, mask, margin=4, zoom=3):
    """Truth | render | outline of one image, cut to the mask's box and zoomed (no smoothing)."""
    rows, columns = torch.nonzero(mask > 0, as_tuple=True)
    v0, v1 = max(int(rows.min()) - margin, 0), int(rows.max()) + margin + 1
    u0, u1 = max(int(columns.min()) - margin, 0), int(columns.max()) + margin + 1
    difference = alpha - mask
    outline = torch.stack([difference.clamp(min=0), torch.zeros_like(difference), (-difference).clamp(min=0)], -1)
    outline = (2 * outline + 0.2 * mask[..., None]).clamp(0, 1)
    panels = [picture[v0:v1, u0:u1].repeat_interleave(zoom, 0).repeat_interleave(zoom, 1)
              for picture in (truth, rgb.clamp(0, 1), outline)]
    return torch.cat(panels, 1)


def stack_rows(rows):
    """Rows of different sizes, left-aligned on white."""
    width = max(row.shape[1] for row in rows)
    padded = [torch.nn.functional.pad(row.permute(2, 0, 1), (0, width - row.shape[1]), value=1.0).permute(1, 2, 0)
              for row in rows]
    return torch.cat(padded, 0)


if __name__ == "__main__":
    main()
