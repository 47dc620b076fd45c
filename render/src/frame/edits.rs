//! Changing a scene between frames: characters moved, hair edited (updates staged and copied by
//! the next frame's first passes), and the content version that invalidates caches.

use super::*;

impl SceneRenderer {
    /// What every cache of this scene is derived from: the revision of each uploaded hair and
    /// the count of placement changes ([`Self::set_character_transform`]; lights and occluder
    /// meshes are fixed for a renderer's life).
    pub fn content_version(&self) -> ContentVersion {
        ContentVersion(self.hairs.iter().map(GpuHair::revision).chain([self.placements]).collect())
    }

    /// Moves scene character `index` (in the scene's order): its hair and its occluder (which
    /// keeps its own placement under the character) are drawn at `transform` (object → world)
    /// from the next frame on. Shadow maps are rendered again; hair volumes, made in the hair's
    /// object space, stay cached.
    pub fn set_character_transform(&mut self, index: usize, transform: Mat4) -> Result<(), RenderError> {
        let Some(slot) = self.slots.get(index).copied() else {
            return Err(RenderError::InvalidView {
                why: format!("character {index} does not exist ({} characters)", self.slots.len()),
            });
        };
        if !transform.is_finite() || transform.determinant().abs() <= f32::EPSILON {
            return Err(RenderError::InvalidView {
                why: format!("character {index}: the transform is not finite and invertible"),
            });
        }
        let list = if slot.stored { &mut self.stored_characters } else { &mut self.characters };
        if list[slot.index].transform == transform {
            return Ok(());
        }
        list[slot.index].transform = transform;
        if let Some((o, local)) = slot.occluder {
            self.occluders[o].transform = transform * local;
            self.occluders[o].hair_transform = transform;
        }
        self.placements += 1;
        Ok(())
    }

    /// The staged hair updates the next frame uploads first: (hair, revision it brings).
    pub(crate) fn staged_hair_updates(&self) -> Vec<(usize, u64)> {
        let staged = self.staged.lock().unwrap_or_else(|e| e.into_inner());
        staged.iter().map(|(h, u)| (*h, u.revision)).collect()
    }

    /// Records the `k`-th staged update's copies (the upload pass).
    pub(crate) fn record_hair_update(&self, rec: &gen_gpu::Recorder<'_>, k: usize) {
        let staged = self.staged.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((h, update)) = staged.get(k) {
            self.hairs[*h].record_update(rec, update);
        }
    }

    /// Brings the hair of the characters with `key` up to date with an edit of its asset
    /// ([`hairmesh::asset::HairAsset::move_vertices`]): only the changed texels and bundle
    /// entries are staged, and the next frame copies them in its first passes (`update hair
    /// …`, in the graph) and renders new shadow maps and volumes for that hair alone. The
    /// asset is the edited one (its style merged as the scene's instance holds it); the report
    /// says what will be sent.
    pub fn update_hair(
        &mut self,
        ctx: &Context,
        key: &str,
        asset: &hairmesh::asset::HairAsset,
        change: &hairmesh::asset::AssetChange,
    ) -> Result<gen_gpu::HairUpdate, RenderError> {
        let Some(&h) = self.hair_keys.get(key) else {
            return Err(RenderError::UnknownHair { key: key.to_owned() });
        };
        let update = self.hairs[h].stage_update(ctx, asset, change)?;
        let report = update.report;
        self.staged.lock().unwrap_or_else(|e| e.into_inner()).push((h, update));
        Ok(report)
    }
}
