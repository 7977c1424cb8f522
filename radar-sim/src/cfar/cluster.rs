//! From exceedances to detections: connected components, peaks with non-maximum suppression
//! and sidelobe editing against the predicted response.

use serde::{Deserialize, Serialize};

use rustfft::num_complex::Complex64;

use super::exact::{residual, source, LookImages, Source, EXACT_MODEL_ERROR};
use super::{CfarMap, ResponseModel, SIDELOBE_MARGIN};
use crate::backproject::Grid;
use rustfft::num_complex::Complex32;

/// One detection.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Detection {
    /// Aperture index.
    pub aperture: usize,
    /// Ground x, m.
    pub x_m: f64,
    /// Ground y, m.
    pub y_m: f64,
    /// Peak image value over the local noise estimate, dB.
    pub snr_db: f64,
    /// Pixels in the cluster.
    pub pixels: usize,
}

/// 8-connected components of the `hits` of an `nx × ny` image: per pixel its component's index
/// (`usize::MAX` for no hit), and each component's size.
pub fn components(hits: &[bool], nx: usize, ny: usize) -> (Vec<usize>, Vec<usize>) {
    let mut label = vec![usize::MAX; nx * ny];
    let mut sizes: Vec<usize> = Vec::new();
    let mut stack = Vec::new();
    for start in 0..(nx * ny).min(hits.len()) {
        if !hits[start] || label[start] != usize::MAX {
            continue;
        }
        let id = sizes.len();
        label[start] = id;
        stack.push(start);
        let mut size = 0usize;
        while let Some(i) = stack.pop() {
            size += 1;
            let (x, y) = ((i % nx) as i64, (i / nx) as i64);
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let (xx, yy) = (x + dx, y + dy);
                    if xx < 0 || yy < 0 || xx >= nx as i64 || yy >= ny as i64 {
                        continue;
                    }
                    let j = yy as usize * nx + xx as usize;
                    if hits[j] && label[j] == usize::MAX {
                        label[j] = id;
                        stack.push(j);
                    }
                }
            }
        }
        sizes.push(size);
    }
    (label, sizes)
}

/// Turns exceedances into detections. Every exceeding pixel that is a local maximum of the
/// image (above its 8 neighbours) is a peak; peaks are taken strongest first, and a peak is
/// suppressed when
/// - a stronger peak already taken lies within `merge_radius_m` (Euclidean; non-maximum
///   suppression between peaks, not pixels, so that a distinct peak next to a strong
///   neighbour's flank is kept), or
/// - with a `model` of the point response, it is no higher than [`SIDELOBE_MARGIN`] times the
///   response that the stronger peaks taken can put there (the coherent sum of their
///   amplitudes times the response's envelope, [`ResponseModel::envelope`]) plus the local
///   noise: a sidelobe of a stronger return, not an object (sidelobe editing).
///
/// Each peak kept is one detection at its sub-pixel position; `pixels` is the size of its
/// 8-connected exceedance region. A peak on the image border is no detection (the response
/// still rises towards the outside, so it belongs to an object beyond the grid, imaged in its
/// own aperture), but it suppresses as any other.
pub fn cluster(
    img: &[f32],
    map: &CfarMap,
    grid: &Grid,
    merge_radius_m: f64,
    aperture: usize,
    model: Option<&ResponseModel>,
) -> Vec<Detection> {
    cluster_with_outside(img, map, grid, &[], merge_radius_m, aperture, model)
}

/// [`cluster`] with the peaks `outside` the grid (ground position, image value on the same
/// scale), found in a guard band imaged around it ([`outside_peaks`]): they take part in the
/// strongest-first pass as any peak, suppressing the grid's peaks within the merge radius and
/// those no higher than their predicted response, but are no detections. A response of an
/// object beyond the grid's edge is thus that object's, and its skirt and sidelobes inside
/// the grid are edited against it.
pub fn cluster_with_outside(
    img: &[f32],
    map: &CfarMap,
    grid: &Grid,
    outside: &[([f64; 2], f64)],
    merge_radius_m: f64,
    aperture: usize,
    model: Option<&ResponseModel>,
) -> Vec<Detection> {
    cluster_edited(
        img,
        map,
        grid,
        outside,
        merge_radius_m,
        aperture,
        model,
        None,
    )
}

/// [`cluster_with_outside`] with, given the complex look images `exact`, sidelobe editing
/// against the exact point response ([`super::ExactResponse`]): each peak taken (the grid's and the
/// band's, detections or not) is a source whose per-look complex amplitude is its look values
/// less the stronger sources' responses there (CLEAN at the peaks), at its sub-pixel position;
/// a candidate peak of the grid is a detection only where its residual after subtracting every
/// stronger source's response, look by look, still reaches its CFAR threshold
/// ([`CfarMap::threshold`]) and exceeds [`EXACT_MODEL_ERROR`]² times the sources' predicted
/// power there. Several objects' sidelobes adding up, and an object's far response where the
/// linearised envelope falls short of it, are thus edited; a weak object in a strong one's
/// sidelobes stays a detection (its residual is its own response).
///
/// `outside` must be `exact`'s band peaks (positions on `exact.band_grid`) for their look
/// values to be read; a band peak whose pixel is not on that grid is no source.
#[allow(clippy::too_many_arguments)]
pub fn cluster_edited(
    img: &[f32],
    map: &CfarMap,
    grid: &Grid,
    outside: &[([f64; 2], f64)],
    merge_radius_m: f64,
    aperture: usize,
    model: Option<&ResponseModel>,
    exact: Option<LookImages<'_>>,
) -> Vec<Detection> {
    let (nx, ny) = (grid.nx, grid.ny);
    if img.len() != nx * ny || map.hits.len() != nx * ny || map.noise.len() != nx * ny {
        return Vec::new();
    }
    let (label, sizes) = components(&map.hits, nx, ny);
    // peaks: exceeding local maxima (equal values: the lower index is the maximum)
    let peaks: Vec<usize> = (0..nx * ny)
        .filter(|&i| {
            if !map.hits[i] {
                return false;
            }
            let (x, y) = ((i % nx) as i64, (i / nx) as i64);
            let v = img[i];
            for dy in -1..=1i64 {
                for dx in -1..=1i64 {
                    let (xx, yy) = (x + dx, y + dy);
                    if (dx == 0 && dy == 0)
                        || xx < 0
                        || yy < 0
                        || xx >= nx as i64
                        || yy >= ny as i64
                    {
                        continue;
                    }
                    let j = yy as usize * nx + xx as usize;
                    if img[j] > v || (img[j] == v && j < i) {
                        return false;
                    }
                }
            }
            true
        })
        .collect();
    // the grid's peaks (Ok: pixel index) and the outside ones (Err: index into `outside`),
    // strongest first
    let mut all: Vec<(f64, std::result::Result<usize, usize>)> = peaks
        .iter()
        .map(|&i| (img[i] as f64, Ok(i)))
        .chain(
            outside
                .iter()
                .enumerate()
                .filter(|(_, (_, v))| v.is_finite())
                .map(|(k, (_, v))| (*v, Err(k))),
        )
        .collect();
    all.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    let r = merge_radius_m.max(grid.spacing_m);
    let mut taken: Vec<([f64; 2], f64)> = Vec::new();
    let mut sources: Vec<Source> = Vec::new();
    let mut out = Vec::new();
    let exact = exact.filter(|e| {
        let n = e.response.looks();
        e.grid.len() == n && e.grid.iter().all(|l| l.len() == nx * ny)
    });
    for (v, which) in all {
        let (pos, noise) = match which {
            Ok(i) => (
                [grid.x(i % nx), grid.y(i / nx)],
                map.noise[i].max(0.0) as f64,
            ),
            Err(k) => (outside[k].0, 0.0),
        };
        let near = taken
            .iter()
            .any(|(q, _)| (q[0] - pos[0]).hypot(q[1] - pos[1]) <= r);
        if near {
            continue;
        }
        if let Some(m) = model {
            let amp: f64 = taken
                .iter()
                .map(|(q, qv)| (qv * m.envelope([pos[0] - q[0], pos[1] - q[1]])).sqrt())
                .sum();
            if v <= SIDELOBE_MARGIN * (amp * amp + noise) {
                continue;
            }
        }
        if let Some(e) = exact {
            // the peak's look values, its sub-pixel position and, for a grid peak, the CLEAN
            // residual against the stronger sources
            let looked = match which {
                Ok(i) => Some((
                    e.grid.iter().map(|l| to64(l[i])).collect::<Vec<_>>(),
                    refined(img, nx, ny, i, grid.spacing_m, pos),
                )),
                Err(_) => band_peak(&e, pos),
            };
            let Some((values, source_pos)) = looked else {
                taken.push((pos, v));
                continue;
            };
            if let Ok(i) = which {
                let (res, pred) = residual(e.response, &sources, pos, &values, e.scale);
                let threshold = map.threshold.get(i).map_or(0.0, |t| f64::from(*t));
                let edited = res < threshold || res <= EXACT_MODEL_ERROR.powi(2) * pred;
                tracing::debug!(
                    aperture,
                    x_m = pos[0],
                    y_m = pos[1],
                    value = v,
                    residual = res,
                    predicted = pred,
                    threshold,
                    edited,
                    "exact sidelobe editing"
                );
                if edited {
                    continue;
                }
            }
            let echo = (
                (e.gains)(source_pos),
                e.ghosts.map(|g| g(source_pos, v)).unwrap_or_default(),
            );
            sources.push(source(e.response, &sources, pos, source_pos, &values, echo));
        }
        taken.push((pos, v));
        let Ok(i) = which else {
            continue;
        };
        let (xu, yu) = (i % nx, i / nx);
        if xu == 0 || yu == 0 || xu + 1 == nx || yu + 1 == ny {
            continue;
        }
        let at = refined(img, nx, ny, i, grid.spacing_m, pos);
        let noise = map.noise[i].max(f32::MIN_POSITIVE) as f64;
        out.push(Detection {
            aperture,
            x_m: at[0],
            y_m: at[1],
            snr_db: 10.0 * (v / noise).log10(),
            pixels: sizes[label[i]],
        });
    }
    out.sort_by(|a, b| b.snr_db.total_cmp(&a.snr_db));
    out
}

fn to64(v: Complex32) -> Complex64 {
    Complex64::new(f64::from(v.re), f64::from(v.im))
}

/// The sub-pixel position of the peak at pixel `i` (position `pos`) of the `nx × ny` image
/// `img` of spacing `spacing_m`: a parabola through it and its neighbours along each axis
/// (the pixel itself on the border).
fn refined(img: &[f32], nx: usize, ny: usize, i: usize, spacing_m: f64, pos: [f64; 2]) -> [f64; 2] {
    let (xu, yu) = (i % nx, i / nx);
    if xu == 0 || yu == 0 || xu + 1 >= nx || yu + 1 >= ny {
        return pos;
    }
    let refine = |a: f32, b: f32, c: f32| -> f64 {
        let (a, b, c) = (a as f64, b as f64, c as f64);
        let den = a - 2.0 * b + c;
        if den < 0.0 {
            (0.5 * (a - c) / den).clamp(-0.5, 0.5)
        } else {
            0.0
        }
    };
    let fx = refine(img[i - 1], img[i], img[i + 1]);
    let fy = refine(img[i - nx], img[i], img[i + nx]);
    [pos[0] + fx * spacing_m, pos[1] + fy * spacing_m]
}

/// A band peak at `pos`: its look values and sub-pixel position from `e`'s band images (on
/// `e.band_grid`); `None` where it is not on that grid.
fn band_peak(e: &LookImages<'_>, pos: [f64; 2]) -> Option<(Vec<Complex64>, [f64; 2])> {
    let bg = e.band_grid?;
    let (nx, ny) = (bg.nx, bg.ny);
    if e.band.len() != e.grid.len() || e.band.iter().any(|l| l.len() != nx * ny) {
        return None;
    }
    let (fx, fy) = bg.index_of(pos);
    let (x, y) = (fx.round(), fy.round());
    if x < 0.0 || y < 0.0 || x >= nx as f64 || y >= ny as f64 {
        return None;
    }
    let (x, y) = (x as usize, y as usize);
    let i = y * nx + x;
    // the 3 × 3 neighbourhood's power, row-major; a border peak is not refined
    let at = if x >= 1 && y >= 1 && x + 1 < nx && y + 1 < ny {
        let power: Vec<f32> = (y - 1..=y + 1)
            .flat_map(|yy| (x - 1..=x + 1).map(move |xx| yy * nx + xx))
            .map(|j| e.band.iter().map(|l| l[j].norm_sqr()).sum())
            .collect();
        refined(&power, 3, 3, 4, bg.spacing_m, pos)
    } else {
        pos
    };
    Some((e.band.iter().map(|l| to64(l[i])).collect(), at))
}

/// The peaks of `band` (an image on `band_grid`, the guard band: a coarser grid around
/// `grid`) that lie outside `grid` and reach `threshold`: local maxima of their 8 neighbours,
/// as (ground position, value), for [`cluster_with_outside`]. An `band` that is not
/// `band_grid`'s gives none.
pub fn outside_peaks(
    band: &[f32],
    band_grid: &Grid,
    grid: &Grid,
    threshold: f64,
) -> Vec<([f64; 2], f64)> {
    let (nx, ny) = (band_grid.nx, band_grid.ny);
    if band.len() != nx * ny || nx < 3 || ny < 3 {
        return Vec::new();
    }
    let half_x = (grid.nx as f64 - 1.0) / 2.0 * grid.spacing_m;
    let half_y = (grid.ny as f64 - 1.0) / 2.0 * grid.spacing_m;
    let mut out = Vec::new();
    for y in 1..ny - 1 {
        for x in 1..nx - 1 {
            let i = y * nx + x;
            let v = band[i];
            if v.is_nan() || (v as f64) < threshold {
                continue;
            }
            let pos = [band_grid.x(x), band_grid.y(y)];
            if (pos[0] - grid.centre_m[0]).abs() <= half_x
                && (pos[1] - grid.centre_m[1]).abs() <= half_y
            {
                continue;
            }
            let is_max = (-1..=1i64).all(|dy| {
                (-1..=1i64).all(|dx| {
                    let j = ((y as i64 + dy) as usize) * nx + (x as i64 + dx) as usize;
                    j == i || band[j] < v || (band[j] == v && j > i)
                })
            });
            if is_max {
                out.push((pos, v as f64));
            }
        }
    }
    out
}
