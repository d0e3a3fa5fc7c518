//! k-means in the plane, for designs placed where the demand is.
//!
//! [`kmeans`] seeds k centres with k-means++ (each new centre drawn with probability
//! proportional to its squared distance from the nearest centre so far) and then runs Lloyd's
//! iterations until no point changes cluster. Different draws land in different local optima of
//! the clustering, which is the point: the oracle's warm restarts start from them
//! (`ParamMdp::clustered_design`), spread over the good basins of a design problem whose
//! relays serve groups of users.

use envpg_core::EnvRng;
use rand::RngExt;

/// Lloyd's iterations stop here even if points still change cluster (they rarely need a tenth).
const MAX_LLOYD: usize = 200;

/// `k` centres of `points` (k ≥ 1, points non-empty): k-means++ seeding from `rng`, then
/// Lloyd's iterations to a fixed point. A centre whose cluster empties keeps its place. The
/// result depends only on the points, `k` and the draws from `rng`.
pub fn kmeans(points: &[[f64; 2]], k: usize, rng: &mut EnvRng) -> Vec<[f64; 2]> {
    assert!(k >= 1 && !points.is_empty(), "k-means needs k >= 1 and at least one point");
    let mut centres = seed_plus_plus(points, k, rng);
    let mut assign = vec![usize::MAX; points.len()];
    for _ in 0..MAX_LLOYD {
        let mut changed = false;
        for (p, a) in points.iter().zip(&mut assign) {
            let j = nearest(&centres, p).0;
            changed |= *a != j;
            *a = j;
        }
        if !changed {
            break;
        }
        let mut sums = vec![[0.0f64; 3]; k];
        for (p, &j) in points.iter().zip(&assign) {
            sums[j][0] += p[0];
            sums[j][1] += p[1];
            sums[j][2] += 1.0;
        }
        for (c, s) in centres.iter_mut().zip(&sums) {
            if s[2] > 0.0 {
                *c = [s[0] / s[2], s[1] / s[2]];
            }
        }
    }
    centres
}

/// k-means++ seeding. Once every point coincides with a centre (k larger than the distinct
/// points), further centres are drawn uniformly.
fn seed_plus_plus(points: &[[f64; 2]], k: usize, rng: &mut EnvRng) -> Vec<[f64; 2]> {
    let mut centres = vec![points[rng.random_range(0..points.len())]];
    let mut d2: Vec<f64> = points.iter().map(|p| dist2(p, &centres[0])).collect();
    while centres.len() < k {
        let total: f64 = d2.iter().sum();
        let pick = if total > 0.0 {
            let target = rng.random::<f64>() * total;
            let mut acc = 0.0;
            // The last point with positive weight catches a target rounding puts past the sum.
            let mut pick = d2.iter().rposition(|&w| w > 0.0).expect("positive total");
            for (i, &w) in d2.iter().enumerate() {
                acc += w;
                if w > 0.0 && acc >= target {
                    pick = i;
                    break;
                }
            }
            pick
        } else {
            rng.random_range(0..points.len())
        };
        let c = points[pick];
        for (d, p) in d2.iter_mut().zip(points) {
            *d = d.min(dist2(p, &c));
        }
        centres.push(c);
    }
    centres
}

/// Index of and squared distance to the nearest centre (lowest index on ties).
fn nearest(centres: &[[f64; 2]], p: &[f64; 2]) -> (usize, f64) {
    centres
        .iter()
        .enumerate()
        .map(|(j, c)| (j, dist2(p, c)))
        .fold((0, f64::INFINITY), |best, cur| if cur.1 < best.1 { cur } else { best })
}

fn dist2(a: &[f64; 2], b: &[f64; 2]) -> f64 {
    (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)
}

#[cfg(test)]
mod tests {
    use super::*;
    use envpg_core::{Purpose, Streams};

    fn rng(seed: u64) -> EnvRng {
        Streams::new(seed).stream(Purpose::Zeta0, 0, 0)
    }

    /// Three tight, far-apart groups: every draw finds their means.
    #[test]
    fn separated_groups_are_found_by_every_draw() {
        let groups = [[0.0, 0.0], [10.0, 0.0], [0.0, 10.0]];
        let offsets = [[0.1, 0.0], [-0.1, 0.0], [0.0, 0.2], [0.0, -0.2]];
        let points: Vec<[f64; 2]> =
            groups.iter().flat_map(|g| offsets.iter().map(move |o| [g[0] + o[0], g[1] + o[1]])).collect();
        for seed in 0..20 {
            let mut c = kmeans(&points, 3, &mut rng(seed));
            c.sort_by(|a, b| a.partial_cmp(b).unwrap());
            let mut want = groups.to_vec();
            want.sort_by(|a, b| a.partial_cmp(b).unwrap());
            for (got, want) in c.iter().zip(&want) {
                assert!(dist2(got, want) < 1e-24, "seed {seed}: {got:?} vs {want:?}");
            }
        }
    }

    /// Lloyd's fixed point: each centre is the mean of the points nearest to it.
    #[test]
    fn centres_are_the_means_of_their_clusters() {
        let mut r = rng(5);
        let points: Vec<[f64; 2]> = (0..300).map(|_| [r.random::<f64>() * 4.0, r.random::<f64>()]).collect();
        let c = kmeans(&points, 5, &mut rng(9));
        for (j, cj) in c.iter().enumerate() {
            let mine: Vec<&[f64; 2]> = points.iter().filter(|p| nearest(&c, p).0 == j).collect();
            assert!(!mine.is_empty());
            let mean = mine.iter().fold([0.0, 0.0], |m, p| [m[0] + p[0], m[1] + p[1]]);
            let n = mine.len() as f64;
            assert!(dist2(cj, &[mean[0] / n, mean[1] / n]) < 1e-20, "centre {j}");
        }
        assert_eq!(c, kmeans(&points, 5, &mut rng(9)), "same draws, same centres");
    }

    /// More centres than distinct points: no panic, every centre on a point.
    #[test]
    fn more_centres_than_points_still_gives_k_centres_on_points() {
        let points = [[1.0, 2.0], [1.0, 2.0], [3.0, 4.0]];
        let c = kmeans(&points, 4, &mut rng(1));
        assert_eq!(c.len(), 4);
        assert!(c.iter().all(|x| points.contains(x)));
    }
}
