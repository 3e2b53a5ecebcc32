//! Label placement for the plots: each label takes the first of its candidate positions
//! whose box stays inside the plot and overlaps no box placed before it (labels in priority
//! order, obstacles such as a legend first); a label with no free candidate is left out and
//! reported, so a crowded figure thins its labels instead of printing them over each other.
//! Pure geometry in pixels (y down), so the figures' tests can check the boxes themselves.

/// An axis-aligned box in pixels: `x0 ≤ x < x1`, `y0 ≤ y < y1` (y grows downwards).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LabelBox {
    /// Left edge.
    pub x0: i32,
    /// Top edge.
    pub y0: i32,
    /// Right edge (exclusive).
    pub x1: i32,
    /// Bottom edge (exclusive).
    pub y1: i32,
}

impl LabelBox {
    /// The box of a `size = (width, height)` label whose top-left corner is `at`.
    pub fn at(at: (i32, i32), size: (u32, u32)) -> Self {
        Self {
            x0: at.0,
            y0: at.1,
            x1: at.0 + size.0 as i32,
            y1: at.1 + size.1 as i32,
        }
    }

    /// True when the two boxes share at least one pixel.
    pub fn overlaps(&self, o: &LabelBox) -> bool {
        self.x0 < o.x1 && o.x0 < self.x1 && self.y0 < o.y1 && o.y0 < self.y1
    }

    /// True when `self` lies entirely within `area`.
    pub fn inside(&self, area: &LabelBox) -> bool {
        self.x0 >= area.x0 && self.x1 <= area.x1 && self.y0 >= area.y0 && self.y1 <= area.y1
    }

    /// The box grown by `m` pixels on every side (the gap kept between labels).
    pub fn grown(&self, m: i32) -> Self {
        Self {
            x0: self.x0 - m,
            y0: self.y0 - m,
            x1: self.x1 + m,
            y1: self.y1 + m,
        }
    }
}

/// A label to place: its size and its candidate top-left corners, best first.
#[derive(Debug, Clone, PartialEq)]
pub struct LabelRequest {
    /// Width and height (pixels) of the rendered text.
    pub size: (u32, u32),
    /// Candidate top-left corners (pixels), in order of preference.
    pub candidates: Vec<(i32, i32)>,
}

/// Places `labels` in the given (priority) order: each takes its first candidate whose box
/// lies inside `area` and keeps at least `gap` pixels from every box placed before it and
/// from every `obstacle`. Returns each label's box, `None` where no candidate was free.
pub fn place_labels(
    labels: &[LabelRequest],
    area: LabelBox,
    obstacles: &[LabelBox],
    gap: i32,
) -> Vec<Option<LabelBox>> {
    let mut taken: Vec<LabelBox> = obstacles.to_vec();
    labels
        .iter()
        .map(|l| {
            let free = l
                .candidates
                .iter()
                .map(|&c| LabelBox::at(c, l.size))
                .find(|b| b.inside(&area) && !taken.iter().any(|t| t.grown(gap).overlaps(b)))?;
            taken.push(free);
            Some(free)
        })
        .collect()
}

/// True when no two of `boxes` overlap (the check the figures' tests apply).
pub fn disjoint(boxes: &[LabelBox]) -> bool {
    boxes
        .iter()
        .enumerate()
        .all(|(i, a)| boxes[i + 1..].iter().all(|b| !a.overlaps(b)))
}

#[cfg(test)]
mod tests {
    use super::*;

    const AREA: LabelBox = LabelBox {
        x0: 0,
        y0: 0,
        x1: 200,
        y1: 100,
    };

    #[test]
    fn overlap_and_inside() {
        let a = LabelBox::at((0, 0), (10, 10));
        assert!(a.overlaps(&LabelBox::at((9, 9), (5, 5))));
        // Touching edges do not overlap (x1 is exclusive).
        assert!(!a.overlaps(&LabelBox::at((10, 0), (5, 5))));
        assert!(a.inside(&AREA));
        assert!(!LabelBox::at((195, 0), (10, 10)).inside(&AREA));
    }

    /// Three labels wanting the same spot: the second and third move to their next free
    /// candidate, a fourth with no free candidate is dropped, and none overlaps another.
    #[test]
    fn crowded_labels_move_or_drop_but_never_overlap() {
        let stacked: Vec<(i32, i32)> = (0..3).map(|k| (50, 10 + 20 * k)).collect();
        let req = |c: Vec<(i32, i32)>| LabelRequest {
            size: (60, 15),
            candidates: c,
        };
        let labels = vec![
            req(stacked.clone()),
            req(stacked.clone()),
            req(stacked.clone()),
            req(stacked),
        ];
        let placed = place_labels(&labels, AREA, &[], 2);
        assert_eq!(placed[0], Some(LabelBox::at((50, 10), (60, 15))));
        assert_eq!(placed[1], Some(LabelBox::at((50, 30), (60, 15))));
        assert_eq!(placed[2], Some(LabelBox::at((50, 50), (60, 15))));
        assert_eq!(placed[3], None);
        let boxes: Vec<LabelBox> = placed.into_iter().flatten().collect();
        assert!(disjoint(&boxes));
        // Without placement, the same requests overlap: the check can fail.
        let naive: Vec<LabelBox> = labels
            .iter()
            .map(|l| LabelBox::at(l.candidates[0], l.size))
            .collect();
        assert!(!disjoint(&naive));
    }

    #[test]
    fn obstacles_and_area_are_respected() {
        let legend = LabelBox::at((0, 0), (100, 50));
        let placed = place_labels(
            &[LabelRequest {
                size: (50, 10),
                candidates: vec![(10, 10), (180, 10), (120, 10)],
            }],
            AREA,
            &[legend],
            0,
        );
        // (10, 10) is under the legend, (180, 10) sticks out of the area.
        assert_eq!(placed, vec![Some(LabelBox::at((120, 10), (50, 10)))]);
    }
}
