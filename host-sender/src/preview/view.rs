//! The four views (top, front, side, isometric) as linear projections, and fitting a view's
//! content into a panel of the picture.

use super::model::{Box3, P3};

/// One of the preview's views.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum View {
    /// Looking down −Z: X right, Y up.
    Top,
    /// Looking from the operator's side (−Y towards +Y): X right, Z up.
    Front,
    /// Looking from the right-hand side (+X towards −X): Y right, Z up.
    Side,
    /// Isometric from front-right-top: X right-down, Y right-up, Z up.
    Iso,
}

impl View {
    pub const ALL: [View; 4] = [View::Top, View::Front, View::Side, View::Iso];

    pub fn title(self) -> &'static str {
        match self {
            View::Top => "Top (XY)",
            View::Front => "Front (XZ)",
            View::Side => "Side (YZ)",
            View::Iso => "Isometric",
        }
    }

    /// Names of the horizontal and vertical screen axes (orthographic views only).
    pub(crate) fn axis_names(self) -> Option<(&'static str, &'static str)> {
        match self {
            View::Top => Some(("X", "Y")),
            View::Front => Some(("X", "Z")),
            View::Side => Some(("Y", "Z")),
            View::Iso => None,
        }
    }

    /// Projects a machine point to view coordinates (mm, x right, y up).
    pub(crate) fn project(self, p: P3) -> (f64, f64) {
        match self {
            View::Top => (p[0], p[1]),
            View::Front => (p[0], p[2]),
            View::Side => (p[1], p[2]),
            View::Iso => {
                // Screen right = (1, 1, 0)/√2, screen up = (−1, 1, 2)/√6: the camera looks from (1, −1, 1).
                let s2 = std::f64::consts::SQRT_2;
                let s6 = 6f64.sqrt();
                ((p[0] + p[1]) / s2, (-p[0] + p[1] + 2.0 * p[2]) / s6)
            }
        }
    }

    /// The 2-D bounds of a box's projection: (min x, min y, max x, max y).
    pub fn bounds(self, b: &Box3) -> [f64; 4] {
        let mut r = [
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        ];
        for c in b.corners() {
            let (x, y) = self.project(c);
            r = [r[0].min(x), r[1].min(y), r[2].max(x), r[3].max(y)];
        }
        r
    }
}

/// Maps view coordinates (mm, y up) to pixels of a panel (y down).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fit {
    pub(crate) view: View,
    /// Pixels per mm.
    pub scale: f64,
    /// Pixel position of view coordinate (0, 0).
    pub(crate) ox: f64,
    pub(crate) oy: f64,
}

impl Fit {
    /// Centres the view bounds `b` in the pixel rectangle `rect` (x, y, w, h) at `scale`.
    pub(crate) fn centred(view: View, b: [f64; 4], rect: [f64; 4], scale: f64) -> Fit {
        let cx = (b[0] + b[2]) / 2.0;
        let cy = (b[1] + b[3]) / 2.0;
        Fit {
            view,
            scale,
            ox: rect[0] + rect[2] / 2.0 - cx * scale,
            oy: rect[1] + rect[3] / 2.0 + cy * scale,
        }
    }

    /// The largest scale at which bounds `b` fit into a `w`×`h` pixel area.
    pub(crate) fn scale_to_fit(b: [f64; 4], w: f64, h: f64) -> f64 {
        let bw = (b[2] - b[0]).max(1e-3);
        let bh = (b[3] - b[1]).max(1e-3);
        (w / bw).min(h / bh)
    }

    /// Pixel position of a machine point.
    pub(crate) fn px(&self, p: P3) -> (f64, f64) {
        let (x, y) = self.view.project(p);
        self.px2(x, y)
    }

    /// Pixel position of a view-coordinate point.
    pub fn px2(&self, x: f64, y: f64) -> (f64, f64) {
        (self.ox + x * self.scale, self.oy - y * self.scale)
    }

    /// View coordinates of a pixel.
    pub(crate) fn unpx(&self, px: f64, py: f64) -> (f64, f64) {
        ((px - self.ox) / self.scale, (self.oy - py) / self.scale)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn iso_axes_point_the_usual_way() {
        let (x, y) = View::Iso.project([1.0, 0.0, 0.0]);
        assert!(x > 0.0 && y < 0.0, "X goes right and down");
        let (x, y) = View::Iso.project([0.0, 1.0, 0.0]);
        assert!(x > 0.0 && y > 0.0, "Y goes right and up");
        let (x, y) = View::Iso.project([0.0, 0.0, 1.0]);
        assert!(x == 0.0 && y > 0.0, "Z goes straight up");
    }

    #[test]
    fn fit_round_trips() {
        let f = Fit::centred(
            View::Top,
            [0.0, 0.0, 60.0, 40.0],
            [10.0, 20.0, 600.0, 400.0],
            5.0,
        );
        let (px, py) = f.px([0.0, 40.0, 7.0]);
        assert_eq!((px, py), (160.0, 120.0));
        assert_eq!(f.unpx(px, py), (0.0, 40.0));
    }
}
