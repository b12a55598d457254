//! Seam padding: UV islands grown outwards by a margin of texels.

/// Grows the texels with alpha > 0 outwards by `margin` rings, as bakers pad UV islands: in each
/// ring, every empty texel (alpha 0) with a filled neighbour among its 8 takes the mean of
/// those neighbours' RGB and alpha 1. Filtering and mip-mapping near a seam then blend the
/// island's own colours instead of the background. `rgba` is row-major, `width × height`.
pub fn dilate(rgba: &mut [[f32; 4]], width: usize, height: usize, margin: usize) {
    debug_assert_eq!(rgba.len(), width * height);
    for _ in 0..margin {
        let mut grown = Vec::new();
        for y in 0..height {
            for x in 0..width {
                if rgba[y * width + x][3] > 0.0 {
                    continue;
                }
                let mut sum = [0.0_f32; 3];
                let mut count = 0u32;
                for ny in y.saturating_sub(1)..=(y + 1).min(height - 1) {
                    for nx in x.saturating_sub(1)..=(x + 1).min(width - 1) {
                        let n = rgba[ny * width + nx];
                        if n[3] > 0.0 {
                            for c in 0..3 {
                                sum[c] += n[c];
                            }
                            count += 1;
                        }
                    }
                }
                if count > 0 {
                    let k = count as f32;
                    grown.push((y * width + x, [sum[0] / k, sum[1] / k, sum[2] / k, 1.0]));
                }
            }
        }
        if grown.is_empty() {
            return;
        }
        for (i, p) in grown {
            rgba[i] = p;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_island_grows_by_the_margin_in_every_direction() {
        let (w, h) = (11, 11);
        let mut rgba = vec![[0.0_f32; 4]; w * h];
        rgba[5 * w + 5] = [0.5, 0.25, 1.0, 1.0];
        dilate(&mut rgba, w, h, 3);
        for y in 0..h {
            for x in 0..w {
                let within = x.abs_diff(5) <= 3 && y.abs_diff(5) <= 3; // 8-neighbour rings: a square
                let p = rgba[y * w + x];
                if within {
                    assert_eq!(p, [0.5, 0.25, 1.0, 1.0], "({x}, {y})");
                } else {
                    assert_eq!(p, [0.0; 4], "({x}, {y})");
                }
            }
        }
    }

    #[test]
    fn padding_averages_the_filled_neighbours_and_keeps_the_island() {
        let (w, h) = (3, 1);
        let mut rgba = vec![[1.0, 0.0, 0.0, 1.0], [0.0; 4], [0.0, 0.0, 1.0, 1.0]];
        dilate(&mut rgba, w, h, 1);
        assert_eq!(rgba, vec![[1.0, 0.0, 0.0, 1.0], [0.5, 0.0, 0.5, 1.0], [0.0, 0.0, 1.0, 1.0]]);
        let before = rgba.clone();
        dilate(&mut rgba, w, h, 0);
        assert_eq!(rgba, before);
    }
}
