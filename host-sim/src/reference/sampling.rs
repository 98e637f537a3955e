//! Reference pixel-area sampling (camera-model.md §7), written from the
//! contract and docs/sensor.md: the pixel square `[i − ½, i + ½] ×
//! [j − ½, j + ½]`, an `n×n` grid of cell centres, and the adaptive rule.

/// The pattern a frame is sampled with: the pixel grid, and the aperture
/// points each of its samples is lit through (§8).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Pattern {
    /// Grid side (1: the centre alone).
    pub n: u8,
    /// The grid only where the corners and centre disagree.
    pub adaptive: bool,
    /// Aperture points (0: the chief ray alone, a pinhole).
    pub aperture: u16,
}

impl Pattern {
    /// One sample at the centre, through a pinhole.
    pub const CENTRE: Pattern = Pattern {
        n: 1,
        adaptive: false,
        aperture: 0,
    };

    /// The converged estimate the sampling error is measured against: 16×16
    /// on every pixel, the same aperture.
    pub fn converged_grid(self) -> Pattern {
        Pattern {
            n: 16,
            adaptive: false,
            ..self
        }
    }

    /// The converged estimate the defocus error is measured against: the
    /// same grid, [`super::defocus::CONVERGED`] aperture points.
    pub fn converged_aperture(self) -> Pattern {
        Pattern {
            aperture: super::defocus::CONVERGED,
            ..self
        }
    }

    /// The grid for an edge-placement budget (docs/sensor.md): the smallest
    /// side in 1, 2, 4, 8, 16 whose worst straight-edge error, half a grid
    /// cell, is within it.
    pub fn for_edge_error(e: f64, adaptive: bool) -> Pattern {
        let n = [1u8, 2, 4, 8, 16]
            .into_iter()
            .find(|&n| 1.0 / (2.0 * f64::from(n)) <= e)
            .unwrap_or(16);
        Pattern {
            n,
            adaptive,
            aperture: 0,
        }
    }

    /// The pattern a scene file's `[sampling]` asks for (one sample at the
    /// centre without it), through the aperture the core's plan samples,
    /// with the grid the plan raises it to there (the planner's rules of
    /// docs/sensor.md decide both, as the contract has the plan report
    /// them).
    pub fn of_scene(r: &crate::scene_file::Resolved) -> Pattern {
        let grid = r.desc.sampling.map_or(Pattern::CENTRE, |s| {
            Pattern::for_edge_error(s.edge_error, s.adaptive)
        });
        let planned = r
            .core_scene()
            .map(|s| hilcam::planner::plan(&s, &hilcam::planner::Budget::default()).options);
        match planned {
            Ok(o) if o.aperture > 0 => Pattern {
                aperture: o.aperture,
                n: grid.n.max(o.samples),
                ..grid
            },
            _ => grid,
        }
    }

    /// Offsets of the grid's cell centres from the pixel centre, pixels.
    pub fn offsets(&self) -> Vec<f64> {
        let n = f64::from(self.n);
        (0..self.n).map(|a| (f64::from(a) + 0.5) / n - 0.5).collect()
    }
}
