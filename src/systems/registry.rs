//! The `kinds!` macro: from the one list of kinds in `systems/mod.rs` it writes `KINDS`, the
//! scene file's format and the default scene. It names no kind itself.

/// Writes, from the one list of kinds in `systems/mod.rs`, `KINDS`, the scene file's format and the
/// default scene. Each entry is a kind (its folder under `systems/`) with its block's type
/// and the block's fields as they appear in the file, flat beside the shared ones. The file
/// is read into `SceneFile` (every field defaults to the default scene's, unknown fields
/// are refused: the old-format messages rely on it) and written from `SceneFields`; both
/// are named `Scene` in the file. A macro, not `#[serde(flatten)]`: RON writes flattened
/// structs as maps with quoted keys, and `deny_unknown_fields` does not work with flatten.
macro_rules! kinds {
    ($(
        $kind:ident : $block:ident { $( $field:ident : $ty:ty ),* $(,)? }
    ),* $(,)?) => {
        /// Every kind of hair Kami knows, in drawing order.
        pub const KINDS: &[&$crate::systems::kind::Kind] = &[$(&$kind::KIND),*];

        impl Default for $crate::systems::scene::Scene {
            /// The file `Scene()`: the default head, camera, light and render settings and
            /// every kind's default block, no hair (not a valid scene by itself: `validate`
            /// asks for some hair).
            fn default() -> Self {
                $crate::systems::scene::Scene {
                    seed: 0,
                    head: Default::default(),
                    forces: Default::default(),
                    camera: Default::default(),
                    light: Default::default(),
                    render: Default::default(),
                    blocks: $crate::systems::scene::Blocks::new(vec![$(
                        Box::new($kind::block::$block::default()),
                    )*]),
                }
            }
        }

        /// The scene file as read: every field, flat.
        #[derive(serde::Deserialize)]
        #[serde(rename = "Scene", deny_unknown_fields, default)]
        struct SceneFile {
            seed: u64,
            head: $crate::scene::Head,
            forces: $crate::scene::ForcesDesc,
            camera: $crate::scene::CameraDesc,
            light: $crate::scene::Light,
            render: $crate::scene::RenderSettings,
            $($( $field: $ty, )*)*
        }

        impl Default for SceneFile {
            fn default() -> Self {
                let s = <$crate::systems::scene::Scene as Default>::default();
                $( let $kind: &$kind::block::$block = s.block(); )*
                SceneFile {
                    seed: s.seed,
                    head: s.head.clone(),
                    forces: s.forces.clone(),
                    camera: s.camera.clone(),
                    light: s.light.clone(),
                    render: s.render.clone(),
                    $($( $field: $kind.$field.clone(), )*)*
                }
            }
        }

        /// The scene file as written: every field, flat, borrowed from the scene.
        #[derive(serde::Serialize)]
        #[serde(rename = "Scene")]
        struct SceneFields<'a> {
            seed: &'a u64,
            head: &'a $crate::scene::Head,
            forces: &'a $crate::scene::ForcesDesc,
            camera: &'a $crate::scene::CameraDesc,
            light: &'a $crate::scene::Light,
            render: &'a $crate::scene::RenderSettings,
            $($( $field: &'a $ty, )*)*
        }

        impl<'de> serde::Deserialize<'de> for $crate::systems::scene::Scene {
            fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
                let f = SceneFile::deserialize(d)?;
                Ok($crate::systems::scene::Scene {
                    seed: f.seed,
                    head: f.head,
                    forces: f.forces,
                    camera: f.camera,
                    light: f.light,
                    render: f.render,
                    blocks: $crate::systems::scene::Blocks::new(vec![$(
                        Box::new($kind::block::$block { $( $field: f.$field, )* }),
                    )*]),
                })
            }
        }

        impl serde::Serialize for $crate::systems::scene::Scene {
            fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
                $( let $kind: &$kind::block::$block = self.block(); )*
                SceneFields {
                    seed: &self.seed,
                    head: &self.head,
                    forces: &self.forces,
                    camera: &self.camera,
                    light: &self.light,
                    render: &self.render,
                    $($( $field: &$kind.$field, )*)*
                }
                .serialize(s)
            }
        }
    };
}
pub(crate) use kinds;
