//! The array's symmetries, from its geometry alone: every permutation of the
//! microphones that an orthogonal map about their centre (a rotation, a mirror, or both)
//! carries onto the microphones themselves. Far-field delays cannot tell a channel order
//! from its image under such a permutation: the image hears every sound as the original
//! hears it from the mapped direction. `ssl check` names these orders instead of
//! choosing one, and a sound from a known direction (`--expect`) tells them apart.

use nalgebra::{Matrix3, Vector3};

/// Positions map onto each other when they land within this share of the smallest
/// spacing (1%: measured positions are not exact; delays cannot tell such a difference).
const TOLERANCE_SHARE: f64 = 0.01;

/// Every symmetry of the microphones at `positions` as a permutation `s` (microphone
/// `i` maps onto microphone `s[i]`), the identity first.
#[doc(hidden)]
pub fn symmetries(positions: &[Vector3<f64>]) -> Vec<Vec<usize>> {
    let m = positions.len();
    let identity: Vec<usize> = (0..m).collect();
    if m < 2 {
        return vec![identity];
    }
    let centre = positions.iter().sum::<Vector3<f64>>() / m as f64;
    let v: Vec<Vector3<f64>> = positions.iter().map(|p| p - centre).collect();
    let mut spacing = f64::INFINITY;
    for a in 0..m {
        for b in a + 1..m {
            spacing = spacing.min((v[a] - v[b]).norm());
        }
    }
    let tol = (TOLERANCE_SHARE * spacing).max(1e-9);
    let basis = basis(&v, tol);
    let mut found = vec![identity.clone()];
    // Images of the basis microphones: each assignment that keeps their lengths and
    // angles fixes one orthogonal map on the positions' span.
    let mut images = vec![0usize; basis.len()];
    assign(&v, &basis, &mut images, 0, tol, &mut |images| {
        if let Some(s) = permutation(&v, &basis, images, tol) {
            if s != identity && !found.contains(&s) {
                found.push(s);
            }
        }
    });
    found
}

/// Up to three microphones whose centred positions span the positions' span, each the
/// farthest from the span of those before it.
fn basis(v: &[Vector3<f64>], tol: f64) -> Vec<usize> {
    let mut chosen: Vec<usize> = Vec::new();
    let mut axes: Vec<Vector3<f64>> = Vec::new();
    while chosen.len() < 3 {
        let residue = |x: &Vector3<f64>| {
            let mut r = *x;
            for a in &axes {
                r -= a * a.dot(&r);
            }
            r
        };
        let Some((i, r)) = v
            .iter()
            .enumerate()
            .map(|(i, x)| (i, residue(x)))
            .max_by(|a, b| a.1.norm().total_cmp(&b.1.norm()))
        else {
            break;
        };
        if r.norm() <= tol {
            break;
        }
        chosen.push(i);
        axes.push(r.normalize());
    }
    chosen
}

/// Calls `visit` with every assignment of distinct images to the basis microphones that
/// keeps their lengths and their dot products with the earlier ones.
fn assign(
    v: &[Vector3<f64>],
    basis: &[usize],
    images: &mut Vec<usize>,
    depth: usize,
    tol: f64,
    visit: &mut impl FnMut(&[usize]),
) {
    if depth == basis.len() {
        visit(images);
        return;
    }
    let b = basis[depth];
    for j in 0..v.len() {
        if images[..depth].contains(&j) || (v[j].norm() - v[b].norm()).abs() > tol {
            continue;
        }
        let scale = v[b].norm().max(tol);
        let keeps = (0..depth)
            .all(|e| (v[j].dot(&v[images[e]]) - v[b].dot(&v[basis[e]])).abs() <= 2.0 * tol * scale);
        if keeps {
            images[depth] = j;
            assign(v, basis, images, depth + 1, tol, visit);
        }
    }
}

/// The permutation the map sending the basis onto `images` makes of the microphones,
/// if it maps every one onto another.
fn permutation(
    v: &[Vector3<f64>],
    basis: &[usize],
    images: &[usize],
    tol: f64,
) -> Option<Vec<usize>> {
    // Complete both triples to bases of space with orthogonal directions: the positions
    // lie in the span of the basis, so the completion does not move them.
    let complete = |cols: Vec<Vector3<f64>>| -> Matrix3<f64> {
        let mut cols = cols;
        while cols.len() < 3 {
            let next = match cols.len() {
                1 => {
                    let a = cols[0];
                    let helper = if a.x.abs() < 0.9 * a.norm() {
                        Vector3::x()
                    } else {
                        Vector3::y()
                    };
                    a.cross(&helper).normalize() * a.norm()
                }
                _ => cols[0].cross(&cols[1]).normalize() * cols[0].norm(),
            };
            cols.push(next);
        }
        Matrix3::from_columns(&cols)
    };
    let from = complete(basis.iter().map(|&i| v[i]).collect());
    let to = complete(images.iter().map(|&i| v[i]).collect());
    let map = to * from.try_inverse()?;
    let mut s = vec![usize::MAX; v.len()];
    for (i, x) in v.iter().enumerate() {
        let y = map * x;
        let j = (0..v.len()).find(|&j| (v[j] - y).norm() <= tol)?;
        if s.contains(&j) {
            return None;
        }
        s[i] = j;
    }
    Some(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn count(p: &[[f64; 3]]) -> usize {
        let v: Vec<Vector3<f64>> = p.iter().map(|x| Vector3::from(*x)).collect();
        let s = symmetries(&v);
        // A group: closed under composition.
        for a in &s {
            for b in &s {
                let ab: Vec<usize> = (0..a.len()).map(|i| a[b[i]]).collect();
                assert!(s.contains(&ab), "not closed");
            }
        }
        s.len()
    }

    #[test]
    fn the_symmetries_of_known_arrays_are_their_groups() {
        // A 50 x 40 x 36 cm box: the three mirrors and their products.
        let mut prism = Vec::new();
        for z in [0.18, -0.18] {
            for (x, y) in [(0.25, 0.2), (0.25, -0.2), (-0.25, -0.2), (-0.25, 0.2)] {
                prism.push([x, y, z]);
            }
        }
        assert_eq!(count(&prism), 8);
        // A regular tetrahedron: every permutation of its four corners.
        let tetra = [
            [1.0, 1.0, 1.0],
            [1.0, -1.0, -1.0],
            [-1.0, 1.0, -1.0],
            [-1.0, -1.0, 1.0],
        ];
        assert_eq!(count(&tetra), 24);
        // A regular hexagon: 6 rotations and 6 mirrors.
        let hexagon: Vec<[f64; 3]> = (0..6)
            .map(|i| {
                let a = i as f64 * std::f64::consts::PI / 3.0;
                [0.05 * a.cos(), 0.05 * a.sin(), 0.0]
            })
            .collect();
        assert_eq!(count(&hexagon), 12);
        // A uniform line: itself and its reversal; an uneven one: itself.
        assert_eq!(
            count(&[[0.0, 0.0, 0.0], [0.03, 0.0, 0.0], [0.06, 0.0, 0.0]]),
            2
        );
        assert_eq!(
            count(&[[0.0, 0.0, 0.0], [0.03, 0.0, 0.0], [0.07, 0.0, 0.0]]),
            1
        );
        // A cube: 48.
        let mut cube = Vec::new();
        for x in [-1.0, 1.0] {
            for y in [-1.0, 1.0] {
                for z in [-1.0, 1.0] {
                    cube.push([x, y, z]);
                }
            }
        }
        assert_eq!(count(&cube), 48);
        // No symmetry at all.
        assert_eq!(
            count(&[
                [0.0, 0.0, 0.0],
                [0.1, 0.0, 0.0],
                [0.0, 0.17, 0.0],
                [0.02, 0.03, 0.11]
            ]),
            1
        );
    }
}
