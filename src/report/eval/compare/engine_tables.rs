//! The engine tables of the comparison report, measured: per material the
//! shape errors of every engine's fit as `ssskit engine` makes it by
//! default (the colour kept, Blender's default method for each version),
//! and of the forward Burley model. `present::kernel_report` only shows
//! them.

use crate::engine::method::SubsurfaceMethod;
use crate::engine::request::{fit_with, Request};
use crate::engine::{burley, Engine, Scene};
use crate::profile::Profile;
use crate::progress::NoProgress;
use rayon::prelude::*;

/// Walks of the Random Walk fit in the report: 2^18, a sixteenth of
/// `ssskit engine`'s, which keeps the main job's engine column to under a
/// CPU second. Their noise adds to the shape error in quadrature (about 4%
/// of r R_d on skin1's red: 8.5% read where the walk's expected profile
/// is 7.9% off): the column shows the shape error with that noise taken
/// out ([`Shape::of_walk`]), and the standard error left (from the walk's
/// two halves), 0.2 to 0.4 point on the reference profiles. The values
/// are those of a fit from the shorter walk, a little worse than `ssskit
/// engine`'s (skin1: 7.9%, 9.1%, 8.1% here, 7.6%, 8.6%, 7.4% from 2^22
/// walks): the column is the method's error to within that.
pub const REPORT_WALKS: usize = 1 << 18;

/// A shape error per channel and, for a Monte Carlo model, its standard
/// error.
#[derive(Clone, Debug, PartialEq)]
pub struct Shape {
    pub shape: [f64; 3],
    pub noise: Option<[f64; 3]>,
}

impl Shape {
    /// A walk's shape error `shape` with its profile's noise taken out
    /// (`WalkProfile::noise_l2` adds in quadrature), and its standard
    /// error.
    pub fn of_walk(shape: [f64; 3], w: &crate::engine::walk_profile::WalkProfile) -> Shape {
        Shape {
            shape: std::array::from_fn(|c| {
                (shape[c] * shape[c] - w.noise_l2[c] * w.noise_l2[c])
                    .max(0.0)
                    .sqrt()
            }),
            noise: Some(w.shape_noise),
        }
    }
}

/// One Burley engine column: the engine, its version key, the method fitted.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Column {
    pub engine: Engine,
    pub version: &'static str,
    pub method: SubsurfaceMethod,
}

impl Column {
    /// The column's header: the engine and version, and the method where
    /// it is not the radial Burley one.
    pub fn label(&self) -> String {
        match self.method {
            SubsurfaceMethod::RandomWalk => format!(
                "{} {} ({})",
                self.engine.name(),
                self.version,
                self.method.ui_name()
            ),
            SubsurfaceMethod::ChristensenBurley => {
                format!("{} {}", self.engine.name(), self.version)
            }
        }
    }
}

/// One material's row; None where a fit is refused (e.g. a profile without
/// all of r, g, b).
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    pub material: String,
    /// Unreal's fit: the Burley fitted column.
    pub burley_fitted: Option<Shape>,
    pub burley_forward: Option<Shape>,
    pub iryoku: Option<Shape>,
    pub godot: Option<Shape>,
    /// Per [`EngineTables::columns`].
    pub burley_engines: Vec<Option<Shape>>,
}

/// The engine tables of a comparison.
#[derive(Clone, Debug, PartialEq)]
pub struct EngineTables {
    pub columns: Vec<Column>,
    /// Each column's header ([`Column::label`]).
    pub labels: Vec<String>,
    pub rows: Vec<Row>,
}

/// Every version of every Burley engine, each with the method `ssskit
/// engine` fits for it by default.
fn columns() -> Vec<Column> {
    [Engine::Unreal, Engine::UnityHdrp, Engine::Blender]
        .into_iter()
        .flat_map(|engine| {
            engine.versions().iter().map(move |v| Column {
                engine,
                version: v.key,
                method: SubsurfaceMethod::default_for(engine, v),
            })
        })
        .collect()
}

/// The shape error of `engine`'s default fit at `version`.
fn shape(engine: Engine, version: Option<&str>, p: &Profile) -> Option<Shape> {
    let req = Request {
        version,
        walks: REPORT_WALKS,
        ..Request::default()
    };
    let fit = fit_with(engine, p, Scene::native(engine), &req, &NoProgress).ok()?;
    Some(match &fit.walk {
        Some(w) => Shape::of_walk(fit.error.shape, w),
        None => Shape {
            shape: fit.error.shape,
            noise: None,
        },
    })
}

/// The engine tables for `materials` with their `profiles`.
pub fn engine_tables(materials: &[String], profiles: &[Profile]) -> EngineTables {
    let columns = columns();
    let rows = materials
        .iter()
        .zip(profiles)
        .map(|(m, p)| {
            let exact = |shape: [f64; 3]| Shape { shape, noise: None };
            // Every fit on its own: all at once, none waiting for another.
            let (burley_engines, (iryoku, godot)) = rayon::join(
                || {
                    columns
                        .par_iter()
                        .map(|c| shape(c.engine, Some(c.version), p))
                        .collect::<Vec<Option<Shape>>>()
                },
                || {
                    rayon::join(
                        || shape(Engine::Iryoku, None, p),
                        || shape(Engine::Godot, None, p),
                    )
                },
            );
            Row {
                material: m.clone(),
                // The first column is Unreal's default version.
                burley_fitted: burley_engines[0].clone(),
                burley_forward: burley::forward_error(p).ok().map(|e| exact(e.shape)),
                iryoku,
                godot,
                burley_engines,
            }
        })
        .collect();
    let labels = columns.iter().map(Column::label).collect();
    EngineTables {
        columns,
        labels,
        rows,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each column scores the method `ssskit engine` fits when none is
    /// asked: Random Walk for Cycles 4.0 to 5.0, Christensen-Burley for the
    /// rest; the first column is Unreal's default version.
    #[test]
    fn each_column_is_the_method_engine_fits_by_default() {
        let cols = columns();
        assert_eq!((cols[0].engine, cols[0].version), (Engine::Unreal, "5.4"));
        for c in &cols {
            let asked = SubsurfaceMethod::resolve(c.engine, Some(c.version), None).unwrap();
            assert_eq!(c.method, asked, "{} {}", c.engine.name(), c.version);
        }
        assert!(cols
            .iter()
            .any(|c| c.engine == Engine::Blender && c.method == SubsurfaceMethod::RandomWalk));
    }

    /// Monte Carlo checks hold to this many standard errors.
    const SIGMAS: f64 = 4.0;

    /// The report's Random Walk shape error, its noise taken out, stands
    /// within its standard error of the shape error of a walk 16 times
    /// longer (whose own noise, 4 times smaller, is taken out too), closer
    /// than the short walk's raw error, which its noise lifts.
    #[test]
    fn the_walks_noise_is_taken_out_of_the_report_column() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/profiles/reference/skin1.json");
        let p = Profile::read(std::path::Path::new(path)).unwrap();
        let fit = |walks| {
            let req = Request {
                walks,
                ..Request::default()
            };
            let f = fit_with(Engine::Blender, &p, Scene::default(), &req, &NoProgress).unwrap();
            let w = f.walk.clone().unwrap();
            (f.error.shape, Shape::of_walk(f.error.shape, &w))
        };
        let (short_raw, short) = fit(1 << 16);
        let (_, long) = fit(1 << 20);
        let (se, se_long) = (short.noise.unwrap(), long.noise.unwrap());
        for c in 0..3 {
            let band = SIGMAS * se[c].hypot(se_long[c]);
            assert!(
                (short.shape[c] - long.shape[c]).abs() <= band,
                "channel {c}: {} from 2^16 walks, {} from 2^20 (band {band})",
                short.shape[c],
                long.shape[c]
            );
            assert!(
                (short.shape[c] - long.shape[c]).abs() < short_raw[c] - long.shape[c],
                "channel {c}: the raw {} is no further above {} than the corrected {}",
                short_raw[c],
                long.shape[c],
                short.shape[c]
            );
        }
    }
}
