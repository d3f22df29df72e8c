//! Hair systems: each kind of hair (Anjyo's strands, Van Gelder's fur, Sakai's wisps, Kazama's
//! strips and the kinds to come) is one self-contained module behind the `HairSystem`
//! interface, listed once in `KINDS`. The stage (`stage`) knows systems only through this
//! module: it asks each kind the scene names to build itself, hands every system the same clock
//! (`FrameCtx`) each frame, and draws them all into one depth-tested pass. The viewer's panels,
//! tools and `--set` keys, its Files list, the CLI's summary line, the shader registry, the
//! fuzzer's words, the limits check, the scene bounds and the scene's checks and files iterate
//! `KINDS` too, so adding a kind is a new folder and one entry in the `kinds!` list below,
//! which writes `KINDS` and the kind's fields of the scene file (docs/adding-a-kind.md).
//!
//! This file is the registry: the list of kinds and what is composed from it (reading,
//! validating and merging whole scenes). The layers below it: `scene` (the scene with each
//! kind's block held by type), `system` (`HairSystem` and its clock), `ui` and `kind` (the
//! `Kind` entry) name no kind; the kinds import those, never this file, so the kinds and the
//! scene are not an import cycle (`tests/it/layers.rs` checks).
//!
//! A system owns everything of its kind: its scene block (`<kind>/block.rs`), CPU references,
//! GPU passes, draw pipelines, its shaders (`shaders/<kind>/`), its egui panels and its viewer
//! state (`ui::KindUi`). It knows no window and imports neither `app` nor `stage`.

pub mod anjyo;
pub mod coverage;
pub mod fur;
pub mod hair_bsdf;
pub mod kind;
pub mod lod;
pub mod raster;
pub mod registry;
pub mod scene;
pub mod splat;
pub mod strips;
pub mod system;
pub mod ui;
pub mod wisps;
pub mod world;

pub use kind::{Kind, KindCommand, Panel};
pub use scene::Scene;
pub use system::{
    Change, DrawSetup, FrameCtx, HairSystem, RasterChoice, StepInfo, SystemStats, View,
};

use crate::error::Result;
use crate::scene::{self as shared, Head, Light, RenderSettings, MAX_STRANDS};
use registry::kinds;
use scene::pick;
use std::path::{Path, PathBuf};

kinds! {
    // Every kind of hair Kami knows, in drawing order: its folder, its block's type (in the
    // kind's `block.rs`, with the fields' docs, defaults and checks) and the block's fields
    // in the file. Adding a kind is its folder and one entry here.
    anjyo: AnjyoBlock {
        groom_load: [f64; 3],
        groups: Vec<anjyo::block::HairGroup>,
        dynamics: Option<anjyo::block::Dynamics>,
    },
    fur: FurBlock { fur: Option<fur::block::Fur> },
    wisps: WispsBlock { wisps: Option<wisps::block::Wisps> },
    strips: StripsBlock { strips: Option<strips::block::Strips> },
}

/// The kind called `name`.
pub fn kind(name: &str) -> Option<&'static Kind> {
    KINDS.iter().copied().find(|k| k.name == name)
}

impl Scene {
    /// Parse and validate a scene from RON text; `origin` names it in errors.
    pub fn from_ron(text: &str, origin: &str) -> Result<Scene> {
        let scene: Scene = shared::parse_str(text, origin)?;
        validate(&scene).map_err(|e| shared::in_file(e, origin))?;
        Ok(scene)
    }

    /// `from_ron` on raw bytes: text that is not UTF-8 is refused with the place of the first
    /// bad byte.
    pub fn from_bytes(bytes: &[u8], origin: &str) -> Result<Scene> {
        let scene: Scene = shared::parse(bytes, origin)?;
        validate(&scene).map_err(|e| shared::in_file(e, origin))?;
        Ok(scene)
    }

    /// The rate of the first file cache a hair group plays (frames per second): what
    /// `kami render --gif/--apng` plays at when no `--fps` is given.
    pub fn cache_fps(&self) -> Option<f64> {
        KINDS.iter().find_map(|k| (k.cache_fps)(self))
    }

    /// A scene showing one strand file (`.hair`, `.obj` polylines, USD in any encoding,
    /// `.abc`), as the hair of the first kind that opens strand files (`Kind::opens`, which
    /// validates what it makes). What `kami view groom.hair` and the Files panel open; a
    /// cache plays its frames.
    pub fn from_strand_file(path: &Path) -> Result<Scene> {
        let open = KINDS
            .iter()
            .find_map(|k| k.opens)
            .expect("a kind opens strand files");
        let scene = open(path)?;
        validate(&scene).map_err(|e| shared::in_file(e, &path.display().to_string()))?;
        Ok(scene)
    }

    /// Read, parse and validate a scene file, then read the files it names (relative to its
    /// folder) so that their errors name them; a strand file (`.hair`, `.obj`, USD, `.abc`)
    /// opens as a scene of its own ([`Scene::from_strand_file`]).
    pub fn load(path: impl AsRef<Path>) -> Result<Scene> {
        let path = path.as_ref();
        if crate::formats::Format::of(path).is_some() {
            return Scene::from_strand_file(path);
        }
        let bytes = shared::read_bytes(path)?;
        let origin = path.display().to_string();
        let mut scene = Scene::from_bytes(&bytes, &origin)?;
        let dir = path.parent().unwrap_or(Path::new(""));
        shared::read_shared_files(&mut scene.head, &mut scene.forces, dir, &origin)?;
        for k in KINDS {
            (k.read_files)(&mut scene, dir, &origin)?;
        }
        Ok(scene)
    }

    /// Every file this scene, loaded from `path` by [`Scene::load`], was read from: `path`
    /// itself, then the files the shared blocks and each kind's block name (each kind's
    /// `Kind::files`), without repeats. The viewer watches them and reloads on a save.
    pub fn files(&self, path: &Path) -> Vec<PathBuf> {
        let dir = path.parent().unwrap_or(Path::new(""));
        let mut all = vec![path.to_path_buf()];
        all.extend(shared::shared_files(&self.head, &self.forces, dir));
        for k in KINDS {
            all.extend((k.files)(self, dir));
        }
        let mut seen = Vec::new();
        all.retain(|p| {
            // One file named two ways (a strand file opened as a scene names itself) is
            // watched once.
            let key = std::fs::canonicalize(p).unwrap_or_else(|_| p.clone());
            let new = !seen.contains(&key);
            seen.push(key);
            new
        });
        all
    }

    /// Total hairs and segments the kinds grow (Anjyo's groups, the fur at full density:
    /// its count is rounded per triangle when groomed, so it is approximate; wisps and strips
    /// are surfaces and ribbons, not counted strands).
    pub fn counts(&self) -> (u64, u64) {
        KINDS.iter().fold((0, 0), |(h, s), k| {
            let (kh, ks) = (k.counts)(self);
            (h + kh, s + ks)
        })
    }
}

/// The scene a reload shows: the file's new version `theirs`, except where the viewer's
/// scene `ours` was edited (it differs from `base`, the file as last loaded) and the file
/// left that part as it was (`theirs` equals `base` there): the viewer's edit stays. Parts
/// are the scene's blocks, and inside the head, light and render blocks each field (the
/// skin colour, light and background the Look panel sets survive an edit of the head's
/// shape in the file), and, while the number of hair groups stays, each group with its
/// material apart (a colour set in the Hair look panel survives an edit of the group's
/// count). Where both changed, the file wins: it was saved last.
pub fn merge_edits(base: &Scene, ours: &Scene, theirs: Scene) -> Scene {
    let (b, o) = (base, ours);
    let mut out = theirs.clone();
    // Destructured, so a new shared field fails to compile until it is merged here too; the
    // kinds' blocks are picked whole, then finer by each kind's `merge`.
    let Scene {
        seed,
        head,
        forces,
        camera,
        light,
        render,
        blocks: _,
    } = theirs.clone();
    let Head {
        center,
        radii,
        color,
        visible,
        mesh,
    } = head;
    let Light {
        direction,
        intensity,
        ambient,
        color: light_color,
    } = light;
    let RenderSettings {
        size,
        background,
        msaa,
        supersample,
        min_width,
        lod_tolerance_px,
        strands,
        shading,
        shadows,
    } = render;
    out.seed = pick(&b.seed, &o.seed, seed);
    out.head = Head {
        center: pick(&b.head.center, &o.head.center, center),
        radii: pick(&b.head.radii, &o.head.radii, radii),
        color: pick(&b.head.color, &o.head.color, color),
        visible: pick(&b.head.visible, &o.head.visible, visible),
        mesh: pick(&b.head.mesh, &o.head.mesh, mesh),
    };
    out.forces = pick(&b.forces, &o.forces, forces);
    out.camera = pick(&b.camera, &o.camera, camera);
    out.light = Light {
        direction: pick(&b.light.direction, &o.light.direction, direction),
        intensity: pick(&b.light.intensity, &o.light.intensity, intensity),
        ambient: pick(&b.light.ambient, &o.light.ambient, ambient),
        color: pick(&b.light.color, &o.light.color, light_color),
    };
    out.render = RenderSettings {
        size: pick(&b.render.size, &o.render.size, size),
        background: pick(&b.render.background, &o.render.background, background),
        msaa: pick(&b.render.msaa, &o.render.msaa, msaa),
        supersample: pick(&b.render.supersample, &o.render.supersample, supersample),
        min_width: pick(&b.render.min_width, &o.render.min_width, min_width),
        lod_tolerance_px: pick(
            &b.render.lod_tolerance_px,
            &o.render.lod_tolerance_px,
            lod_tolerance_px,
        ),
        strands: pick(&b.render.strands, &o.render.strands, strands),
        shading: pick(&b.render.shading, &o.render.shading, shading),
        shadows: pick(&b.render.shadows, &o.render.shadows, shadows),
    };
    out.blocks.pick(&b.blocks, &o.blocks);
    for k in KINDS {
        (k.merge)(b, o, &theirs, &mut out);
    }
    out
}

/// Check every field of a parsed scene: the shared blocks, that it shows some hair, each
/// kind's block, then the total strand count. Errors name the field; the loader adds the
/// file.
pub fn validate(s: &Scene) -> Result<()> {
    shared::validate::shared(&s.head, &s.forces, &s.camera, &s.light, &s.render)?;
    if !KINDS.iter().any(|k| (k.in_scene)(s)) {
        let names: Vec<&str> = KINDS.iter().map(|k| k.called).collect();
        let (last, rest) = names.split_last().expect("KINDS is not empty");
        return Err(shared::validate::bad(
            KINDS[0].block,
            "[]",
            &format!("a scene needs at least one {} or {last}", rest.join(", ")),
        ));
    }
    for k in KINDS {
        (k.validate)(s)?;
    }
    // The total last: each kind's own count check names its field first.
    let (strands, _) = s.counts();
    if strands > MAX_STRANDS {
        let counted: Vec<&str> = KINDS
            .iter()
            .filter(|k| (k.in_scene)(s))
            .filter_map(|k| k.counted)
            .collect();
        return Err(shared::validate::bad(
            &counted.join(" + "),
            strands,
            &format!("the total must be at most {MAX_STRANDS} hairs"),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::Scene;
    use crate::error::KamiError;
    use crate::scene::forces::EARTH_GRAVITY;

    /// A small valid scene in the old form: `field` spliced in where it used to sit.
    fn old(top: &str, dynamics: &str, motion: &str) -> String {
        format!(
            "Scene(\n    head: Head(radii: (9.6, 11.5, 7.8)),\n{top}    strips: Some(Strips(\n        \
             layers: [Layer(count: 2, polar: 60.0, azimuth: (0.0, 90.0), length: 10.0, sticks: 4)],\n        \
             motion: Motion({motion}),\n    )),\n    dynamics: Some(Dynamics({dynamics})),\n)\n"
        )
    }

    /// Every field of the old format that held a force fails with a parse error that names
    /// the file and the line, the old field and where it is now.
    #[test]
    fn old_forms_name_the_moved_field_and_where_it_goes() {
        let cases = [
            (
                old("", "gravity: (0.0, -150.0, 0.0)", ""),
                7,
                "`dynamics.gravity` moved",
                "forces: ForcesDesc(gravity:",
            ),
            (
                old(
                    "",
                    "wind: [WindKey(frame: 0.0, force: (1.0, 0.0, 0.0))]",
                    "",
                ),
                7,
                "`dynamics.wind` moved",
                "forces: ForcesDesc(wind:",
            ),
            (
                old("", "head_motion: [HeadKey(frame: 0.0)]", ""),
                7,
                "`dynamics.head_motion` moved",
                "forces: ForcesDesc(head_motion:",
            ),
            (
                old("    eff: Some(EffDesc()),\n", "", ""),
                3,
                "the top-level `eff` moved",
                "forces: ForcesDesc(eff: Some(EffDesc(",
            ),
            (
                old(
                    "    head_capture: Some(HeadCapture(file: \"x.bvh\")),\n",
                    "",
                    "",
                ),
                3,
                "the top-level `head_capture` moved",
                "ForcesDesc(head_capture:",
            ),
            (
                old("    gravity: (0.0, -1.0, 0.0),\n", "", ""),
                3,
                "is now `groom_load`",
                "forces: ForcesDesc(gravity:",
            ),
            (
                old("", "", "gravity: (0.0, -980.0, 0.0)"),
                5,
                "`strips.motion.gravity` moved",
                "forces: ForcesDesc(gravity: (x, y, z))",
            ),
        ];
        for (text, want_line, what, where_now) in cases {
            match Scene::from_ron(&text, "old.ron") {
                Err(KamiError::Parse {
                    path,
                    line,
                    message,
                    ..
                }) => {
                    assert_eq!((path.as_str(), line), ("old.ron", want_line), "{message}");
                    assert!(
                        message.contains(what) && message.contains(where_now),
                        "expected {what:?} and {where_now:?} in: {message}\n{text}"
                    );
                }
                other => panic!("expected a parse error for\n{text}\ngot {other:?}"),
            }
        }
        // The same scene in the new form loads.
        let new = old(
            "    forces: ForcesDesc(gravity: (0.0, -980.0, 0.0)),\n",
            "",
            "",
        );
        let scene = Scene::from_ron(&new, "new.ron").unwrap();
        assert_eq!(scene.forces.gravity, EARTH_GRAVITY);
    }

    /// Every shipped scene is in the new form and loads (its files read, every value
    /// checked); the ones that move under the world's forces say so in their `forces` block.
    #[test]
    fn every_shipped_scene_loads() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/scenes");
        let mut names: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "ron"))
            .collect();
        names.sort();
        assert!(
            names.len() >= 26,
            "{} scenes in {}",
            names.len(),
            dir.display()
        );
        for p in &names {
            let scene = Scene::load(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
            let f = &scene.forces;
            // Strips and wisps on springs fall under Earth's gravity in every shipped scene.
            let falls = scene.strips().is_some()
                || scene.wisps().as_ref().is_some_and(|w| w.springs.is_some());
            if falls {
                assert_eq!(f.gravity, EARTH_GRAVITY, "{}", p.display());
            }
            if let Some(hc) = &f.head_capture {
                assert!(!hc.keys.is_empty(), "{}: the capture was read", p.display());
            }
            if let Some(e) = &f.eff {
                assert_eq!(e.file.is_some(), e.loaded.is_some(), "{}", p.display());
            }
        }
    }

    /// The file format is every shared field, then each kind's, flat, as `kinds!` lists
    /// them: a shipped scene written and read back is the same scene, and a default scene
    /// writes every field once, in that order.
    #[test]
    fn scenes_write_flat_and_read_back_the_same() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/scenes");
        for e in std::fs::read_dir(&dir).unwrap() {
            let p = e.unwrap().path();
            if p.extension().is_none_or(|x| x != "ron") {
                continue;
            }
            let text = std::fs::read_to_string(&p).unwrap();
            let scene = Scene::from_ron(&text, "a.ron").unwrap();
            let back = Scene::from_ron(&scene.to_ron(), "b.ron").unwrap();
            assert!(back == scene, "{}", p.display());
        }
        let text = Scene::default().to_ron();
        let fields = [
            "seed",
            "head",
            "forces",
            "camera",
            "light",
            "render",
            "groom_load",
            "groups",
            "dynamics",
            "fur",
            "wisps",
            "strips",
        ];
        let at: Vec<usize> = fields
            .iter()
            .map(|f| {
                let key = format!("\n    {f}: ");
                assert_eq!(text.matches(&key).count(), 1, "{f} in\n{text}");
                text.find(&key).unwrap()
            })
            .collect();
        assert!(at.windows(2).all(|w| w[0] < w[1]), "{text}");
        assert!(text.starts_with("Scene("), "{text}");
    }

    /// The field and text of a check's error.
    fn invalid(text: &str) -> (String, String) {
        match Scene::from_ron(text, "t.ron") {
            Err(KamiError::Invalid { field, allowed, .. }) => (field, allowed),
            other => panic!("expected an invalid field for\n{text}\ngot {other:?}"),
        }
    }

    /// A scene with no hair names every kind it could have held, from `KINDS`.
    #[test]
    fn a_scene_without_hair_names_every_kind() {
        let (field, allowed) = invalid("Scene()");
        assert_eq!(field, "groups");
        assert_eq!(
            allowed,
            "a scene needs at least one hair group, fur, wisps or strips"
        );
    }

    /// Each kind's own count check comes before the scene's total, so a fur block over the
    /// limit is refused by the fur's rule, naming its field, with hair groups beside it too.
    #[test]
    fn a_kind_over_the_strand_limit_is_named_by_its_own_check() {
        let fur = "fur: Some(Fur(mesh: Critter, hairs: 4000001, length: 0.3, \
                   coats: [Coat(share: 1.0, stiffness: 0.5)]))";
        let group = "groups: [HairGroup(count: 10, segments: 4, length: 10.0, rigidity: 1000.0)]";
        for text in [format!("Scene({fur})"), format!("Scene({group}, {fur})")] {
            let (field, allowed) = invalid(&text);
            assert_eq!(field, "fur.hairs", "{text}");
            assert!(!allowed.contains("total"), "{text}: {allowed}");
        }
        // Within each kind's limit but over the scene's total: the total names both.
        let both = format!(
            "Scene(groups: [HairGroup(count: 3000000, segments: 4, length: 10.0, rigidity: 1000.0)], {})",
            fur.replace("4000001", "2000000")
        );
        let (field, allowed) = invalid(&both);
        assert_eq!(field, "groups[..].count + fur.hairs");
        assert!(
            allowed.contains("the total must be at most 4000000"),
            "{allowed}"
        );
    }

    fn shipped(stem: &str) -> (std::path::PathBuf, Scene) {
        let path = crate::scene::shipped(&format!("assets/scenes/{stem}.ron"));
        let scene = Scene::load(&path).unwrap();
        (path, scene)
    }

    /// What live reload watches: the scene file, then each file it names, as found on disk;
    /// a system mesh (`CgalDemo`) is not the user's and is left out.
    #[test]
    fn files_are_the_scene_and_the_files_it_names() {
        let names = |stem: &str| -> Vec<String> {
            let (path, scene) = shipped(stem);
            let files = scene.files(&path);
            assert_eq!(files[0], path, "{stem}: the scene file first");
            for f in &files {
                assert!(f.is_file(), "{stem}: {} is not a file", f.display());
            }
            files[1..]
                .iter()
                .map(|f| f.file_name().unwrap().to_string_lossy().into_owned())
                .collect()
        };
        assert_eq!(names("imported_groom"), ["wavy.hair"]);
        assert_eq!(names("eff_capture"), ["capture.eff"]);
        assert_eq!(names("fur_creature"), ["creature.gltf"]);
        assert!(names("gust").is_empty());
        assert!(names("mesh_head").is_empty());
        // A strand file opened as a scene names itself: watched once.
        let hair = crate::scene::shipped("assets/grooms/wavy.hair");
        let scene = Scene::load(&hair).unwrap();
        assert_eq!(scene.files(&hair), [hair]);
    }

    /// A reload keeps what the viewer edited where the file did not change that part, takes
    /// the file's edits everywhere else, and lets the file win where both changed.
    #[test]
    fn a_reload_keeps_the_viewers_edits_the_file_left_alone() {
        use super::merge_edits;
        let (_, base) = shipped("gust");
        let mut ours = base.clone();
        ours.light.intensity = 2.5;
        ours.head.color = [0.1, 0.2, 0.3];
        ours.groups_mut()[0].material.color = [0.9, 0.1, 0.1];
        let mut theirs = base.clone();
        theirs.groups_mut()[0].count += 10;
        theirs.render.background = [0.0, 0.0, 0.0];
        theirs.head.radii[0] += 1.0;
        let m = merge_edits(&base, &ours, theirs.clone());
        assert_eq!(m.light.intensity, 2.5, "the viewer's light stays");
        assert_eq!(m.head.color, [0.1, 0.2, 0.3], "the viewer's skin stays");
        assert_eq!(
            m.groups()[0].material.color,
            [0.9, 0.1, 0.1],
            "the viewer's colour stays"
        );
        assert_eq!(
            m.groups()[0].count,
            theirs.groups()[0].count,
            "the file's count"
        );
        assert_eq!(m.render.background, [0.0; 3], "the file's background");
        assert_eq!(m.head.radii, theirs.head.radii, "the file's head");
        // Both changed the colour: the file, saved last, wins.
        theirs.groups_mut()[0].material.color = [0.2, 0.9, 0.2];
        let m = merge_edits(&base, &ours, theirs.clone());
        assert_eq!(m.groups()[0].material.color, [0.2, 0.9, 0.2]);
        // A group added in the file: the groups come from the file as a whole.
        let first = theirs.groups()[0].clone();
        theirs.groups_mut().push(first);
        let m = merge_edits(&base, &ours, theirs.clone());
        assert_eq!(m.groups(), theirs.groups());
        // No viewer edits: the file as written.
        assert_eq!(merge_edits(&base, &base, theirs.clone()), theirs);
    }
}
