"""Image correlation of the rendered images with muDIC (Q4 global DIC), tile by tile.

muDIC's Q4 solver assembles and inverts a dense ``2 n_nodes x 2 n_nodes`` matrix, so a mesh of
the whole image (2e4 elements) does not fit; the region of interest is cut into tiles of at
most ``tile x tile`` elements on one global element grid, each tile correlated on its own
(its own mesh on a crop of the images), in parallel processes. Each element gives one strain
per image at its centre (muDIC's ``Fields``: true strain from the element's four nodes); the
element-centre grids of the tiles join into one grid with no seam of missing points.

Quality: like DICe's ``SIGMA``, each element gets the predicted standard deviation of its
displacement [px], ``noise / sqrt(sum |grad I|^2)`` over its pixels in the reference image;
an element whose value exceeds ``reject`` times the median is a lost subset (glare).
"""

from __future__ import annotations

import logging
from concurrent.futures import ProcessPoolExecutor

import numpy as np
from scipy import ndimage


def _tile(job: tuple) -> tuple:
    """Strains `3 x nx x ny x frames` (xx, yy, xy) of one tile and whether every frame converged."""
    images, x0, y0, el, nx, ny = job
    import muDIC as dic

    logging.getLogger().setLevel(logging.WARNING)
    stack = dic.image_stack_from_list(list(images))
    mesh = dic.Mesher(type="q4").mesh(stack, Xc1=float(x0), Xc2=float(x0 + el * nx), Yc1=float(y0),
                                      Yc2=float(y0 + el * ny), n_elx=int(nx), n_ely=int(ny), GUI=False)
    settings = dic.DICInput(mesh, stack, ref_update_frames=[len(images) + 1], maxit=60)
    results = dic.DICAnalysis(settings).run()
    strain = dic.Fields(results).true_strain()[0]  # 2 x 2 x nx x ny x frames
    out = np.stack([strain[0, 0], strain[1, 1], strain[0, 1]])
    return out, bool(np.isfinite(out).all())


def correlate(images: list[np.ndarray], corner: tuple[int, int], element: int, n: tuple[int, int],
              tile: int = 40, pad: int = 40, workers: int = 2) -> np.ndarray:
    """Strains [-] `3 x n_x x n_y x frames` at the element centres of the global element grid.

    Args:
        images: the reference first, then the deformed images (`rows x cols` grey levels).
        corner: ``(column, row)`` [px] of the grid's first element corner.
        element: element side [px]; n: elements ``(n_x, n_y)``.
        tile: largest tile side [elements]; pad: pixels kept around a tile's crop.
        workers: parallel processes.
    """
    cuts_x = np.linspace(0, n[0], int(np.ceil(n[0] / tile)) + 1).round().astype(int)
    cuts_y = np.linspace(0, n[1], int(np.ceil(n[1] / tile)) + 1).round().astype(int)
    jobs, where = [], []
    for i0, i1 in zip(cuts_x[:-1], cuts_x[1:]):
        for j0, j1 in zip(cuts_y[:-1], cuts_y[1:]):
            c0, r0 = corner[0] + i0 * element - pad, corner[1] + j0 * element - pad
            c1, r1 = corner[0] + i1 * element + pad, corner[1] + j1 * element + pad
            crops = np.stack([im[r0:r1, c0:c1] for im in images])
            jobs.append((crops, pad, pad, element, i1 - i0, j1 - j0))
            where.append((i0, i1, j0, j1))
    out = np.full((3, n[0], n[1], len(images)), np.nan)
    with ProcessPoolExecutor(workers) as pool:
        for (i0, i1, j0, j1), (strain, ok) in zip(where, pool.map(_tile, jobs)):
            out[:, i0:i1, j0:j1] = strain
            if not ok:
                logging.warning("tile %s: non-finite strains", (i0, j0))
    return out


def element_sigma(reference: np.ndarray, corner: tuple[int, int], element: int, n: tuple[int, int],
                  noise: float) -> np.ndarray:
    """Predicted displacement sd [px] `n_x x n_y` of each element from the reference's gradients."""
    gy, gx = np.gradient(reference.astype(np.float64))
    energy = ndimage.uniform_filter(gx**2 + gy**2, size=element) * element**2  # sum over an element
    centres_c = corner[0] + element * np.arange(n[0]) + element // 2
    centres_r = corner[1] + element * np.arange(n[1]) + element // 2
    return noise / np.sqrt(energy[np.ix_(centres_r, centres_c)].T)


def upscale(values: np.ndarray, factor: int) -> np.ndarray:
    """Bilinear values between element centres, ``factor`` points per element (as muDIC's
    ``Fields(upscale=...)``): `n_x x n_y` -> `((n_x - 1) factor + 1) x ((n_y - 1) factor + 1)`."""
    fx = np.arange((values.shape[0] - 1) * factor + 1) / factor
    fy = np.arange((values.shape[1] - 1) * factor + 1) / factor
    gx, gy = np.meshgrid(fx, fy, indexing="ij")
    return ndimage.map_coordinates(values, [gx, gy], order=1)
