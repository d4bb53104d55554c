//! `engine::fit` and `engine::fit_version` take Blender's subsurface
//! method by the one rule of `SubsurfaceMethod::resolve`, the rule `ssskit
//! engine`, Python's `engine_params` and the report's engine tables use:
//! for every engine's default version and Blender's others, the fit asked
//! for no method is a Random Walk fit (it carries the walked profile)
//! exactly where the rule answers Random Walk.

use ssskit::engine::method::SubsurfaceMethod;
use ssskit::engine::{self, Engine, Scene};
use ssskit::profile::Profile;
use std::path::Path;

#[test]
fn default_fits_take_the_method_resolve_gives() {
    let p = Profile::read(Path::new("profiles/reference/skin1.json")).unwrap();
    // Every engine's default (engine::fit), and Blender's other versions,
    // the only ones where resolve's answer may change (one Random Walk
    // fit in all: the walk is the slow one).
    let blender_others = Engine::Blender.versions()[1..].iter();
    let asks = Engine::ALL
        .iter()
        .map(|&e| (e, None))
        .chain(blender_others.map(|v| (Engine::Blender, Some(v.key))));
    let mut walks = 0;
    for (e, version) in asks {
        let rule = SubsurfaceMethod::resolve(e, version, None).unwrap();
        let fit = match version {
            None => engine::fit(e, &p, Scene::native(e)),
            Some(_) => engine::fit_version(e, &p, Scene::native(e), version),
        };
        let walk = rule == SubsurfaceMethod::RandomWalk;
        assert_eq!(
            fit.unwrap().walk.is_some(),
            walk,
            "{} version {version:?}: resolve says {rule:?}",
            e.name()
        );
        walks += usize::from(walk);
    }
    // Blender's default walks and its older versions do not: the check
    // above saw both methods.
    assert_eq!(walks, 1, "default fits that walk");
}
