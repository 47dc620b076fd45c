//! Checking a loaded scene: every value in range and every file it names usable, each error
//! naming the scene, the field and the problem.

use super::*;

pub(super) fn validate(loaded: &LoadedScene) -> Result<(), SceneError> {
    validate_with(loaded, true)
}

/// [`validate`], with or without the character list (an in-memory instance brings its own).
pub(super) fn validate_with(loaded: &LoadedScene, characters: bool) -> Result<(), SceneError> {
    let s = &loaded.scene;
    let path = &loaded.path;
    let invalid = |field: &str, message: String| SceneError::Invalid {
        path: path.clone(),
        field: field.into(),
        message,
    };
    let finite = |field: &str, v: &[f32]| -> Result<(), SceneError> {
        if v.iter().all(|x| x.is_finite()) {
            Ok(())
        } else {
            Err(invalid(field, format!("{v:?} is not finite")))
        }
    };
    let validate_transform = |field: &str, t: &TransformDesc| -> Result<(), SceneError> {
        finite(&format!("{field}.translation"), &t.translation)?;
        finite(&format!("{field}.rotation_y_degrees"), &[t.rotation_y_degrees])?;
        match t.scale {
            Some(scale) if !(scale.is_finite() && scale > 0.0) => {
                Err(invalid(&format!("{field}.scale"), format!("{scale} (expected a positive number)")))
            }
            _ => Ok(()),
        }
    };
    let o = s.output;
    if o.width == 0 || o.height == 0 || o.width > MAX_OUTPUT_SIDE || o.height > MAX_OUTPUT_SIDE {
        return Err(invalid(
            "output",
            format!("{}×{} (each side must be 1..={MAX_OUTPUT_SIDE})", o.width, o.height),
        ));
    }
    finite("camera.eye", &s.camera.eye)?;
    finite("camera.target", &s.camera.target)?;
    if !(1.0..=179.0).contains(&s.camera.fov_y_degrees) {
        return Err(invalid(
            "camera.fov_y_degrees",
            format!("{} (expected 1..=179)", s.camera.fov_y_degrees),
        ));
    }
    if Vec3::from_array(s.camera.eye).distance(Vec3::from_array(s.camera.target)) <= 0.0 {
        return Err(invalid("camera", "eye and target are the same point".into()));
    }
    if s.camera_path.len() == 1 || s.camera_path.len() > 10_000 {
        return Err(invalid(
            "camera_path",
            format!("{} keys (expected none, or 2..=10000)", s.camera_path.len()),
        ));
    }
    for (i, k) in s.camera_path.iter().enumerate() {
        finite(&format!("camera_path[{i}].eye"), &k.eye)?;
        finite(&format!("camera_path[{i}].target"), &k.target)?;
        if Vec3::from_array(k.eye).distance(Vec3::from_array(k.target)) <= 0.0 {
            return Err(invalid(&format!("camera_path[{i}]"), "eye and target are the same point".into()));
        }
    }
    if s.lights.len() > MAX_LIGHTS {
        return Err(invalid("lights", format!("{} lights (at most {MAX_LIGHTS})", s.lights.len())));
    }
    finite("output.background", &o.background)?;
    for (i, l) in s.lights.iter().enumerate() {
        let (v, c) = match l {
            Light::Directional { direction, color, .. } => (direction, color),
            Light::Point { position, color, .. } => (position, color),
        };
        finite(&format!("lights[{i}]"), v)?;
        finite(&format!("lights[{i}].color"), c)?;
        if let Light::Directional { direction, .. } = l
            && Vec3::from_array(*direction).length() <= 0.0
        {
            return Err(invalid(&format!("lights[{i}].direction"), "is zero".into()));
        }
    }
    if characters && (s.characters.is_empty() || s.characters.len() > MAX_CHARACTERS) {
        return Err(invalid(
            "characters",
            format!("{} characters (expected 1..={MAX_CHARACTERS})", s.characters.len()),
        ));
    }
    for (i, c) in s.characters.iter().enumerate() {
        let field = format!("characters[{i}]");
        validate_transform(&format!("{field}.transform"), &c.transform)?;
        finite(&format!("{field}.color"), &c.color)?;
        let hair = loaded.hair_path(c);
        if let Some(w) = c.strand_width
            && !(w.is_finite() && w > 0.0)
        {
            return Err(invalid(
                &format!("{field}.strand_width"),
                format!("{w} (expected a positive number)"),
            ));
        }
        if !hair.exists() {
            return Err(invalid(&format!("{field}.hair"), format!("{} does not exist", hair.display())));
        }
        if let Some(occluder) = &c.occluder {
            finite(&format!("{field}.occluder.color"), &occluder.color)?;
            validate_transform(&format!("{field}.occluder.transform"), &occluder.transform)?;
            let mesh = loaded.resolve(&occluder.mesh);
            if !mesh.is_file() {
                let what = match std::fs::metadata(&mesh) {
                    Ok(m) => format!("is {}, not a mesh file", hairmesh::input::describe(&m)),
                    Err(_) => "does not exist".into(),
                };
                return Err(invalid(&format!("{field}.occluder.mesh"), format!("{} {what}", mesh.display())));
            }
        }
    }
    let l = s.lod;
    if !(l.strand_alpha.is_finite()
        && l.strand_alpha > 0.0
        && l.vertex_alpha.is_finite()
        && l.vertex_alpha > 0.0)
    {
        return Err(invalid("lod", "alphas must be positive".into()));
    }
    if !(l.vertex_error_pixels.is_finite() && l.vertex_error_pixels >= 0.0) {
        return Err(invalid(
            "lod.vertex_error_pixels",
            format!("{} (expected a number of pixels, at least 0)", l.vertex_error_pixels),
        ));
    }
    let e = s.effects;
    if ![1, 2, 4, 8].contains(&e.msaa) {
        return Err(invalid("effects.msaa", format!("{} (expected 1, 2, 4 or 8)", e.msaa)));
    }
    if e.msaa > 1 && e.transparency == Transparency::Oit {
        return Err(invalid(
            "effects.msaa",
            format!("{} with transparency \"oit\" (MSAA anti-aliases the opaque and blended modes)", e.msaa),
        ));
    }
    if e.raster == Raster::Compute && e.msaa > 1 {
        return Err(invalid(
            "effects.msaa",
            format!("{} with raster \"compute\" (MSAA applies to the triangle raster)", e.msaa),
        ));
    }
    if e.shadows {
        if !(16..=4096).contains(&e.shadow_map_size) {
            return Err(invalid(
                "effects.shadow_map_size",
                format!("{} (expected 16..=4096)", e.shadow_map_size),
            ));
        }
        let l = e.shadow_layers;
        if !(l.iter().all(|x| x.is_finite() && *x > 0.0) && l[0] < l[1] && l[1] < l[2]) {
            return Err(invalid(
                "effects.shadow_layers",
                format!("{l:?} (expected three increasing positive numbers)"),
            ));
        }
    }
    if !(1..=16).contains(&e.oit_k) {
        return Err(invalid("effects.oit_k", format!("{} (expected 1..=16)", e.oit_k)));
    }
    if !(e.oit_nodes_per_pixel.is_finite() && e.oit_nodes_per_pixel > 0.0 && e.oit_nodes_per_pixel <= 256.0) {
        return Err(invalid(
            "effects.oit_nodes_per_pixel",
            format!("{} (expected more than 0, at most 256)", e.oit_nodes_per_pixel),
        ));
    }
    if e.ao && !(e.ao_radius.is_finite() && e.ao_radius > 0.0 && e.ao_radius <= 0.5) {
        return Err(invalid(
            "effects.ao_radius",
            format!("{} (expected more than 0, at most 0.5)", e.ao_radius),
        ));
    }
    if e.volume_lod && !(e.volume_lod_pixels.is_finite() && e.volume_lod_pixels >= 0.0) {
        return Err(invalid(
            "effects.volume_lod_pixels",
            format!("{} (expected a number of pixels, at least 0)", e.volume_lod_pixels),
        ));
    }
    if e.uses_volumes()
        && !(e.volume_resolution.is_power_of_two()
            && (crate::volume::MIN_RESOLUTION..=crate::volume::MAX_RESOLUTION).contains(&e.volume_resolution))
    {
        return Err(invalid(
            "effects.volume_resolution",
            format!(
                "{} (expected a power of two from {} to {})",
                e.volume_resolution,
                crate::volume::MIN_RESOLUTION,
                crate::volume::MAX_RESOLUTION
            ),
        ));
    }
    if e.volume_lod && e.raster == Raster::Triangles {
        return Err(invalid(
            "effects.volume_lod",
            "needs the compute rasterizer (raster \"auto\" or \"compute\"): the raymarched samples go \
             through its visibility buffer"
                .into(),
        ));
    }
    if let Some(a) = s.animation {
        if !(1..=MAX_FRAMES).contains(&a.frames) {
            return Err(invalid("animation.frames", format!("{} (expected 1..={MAX_FRAMES})", a.frames)));
        }
        if !(a.fps.is_finite() && a.fps > 0.0 && a.fps <= 1000.0) {
            return Err(invalid(
                "animation.fps",
                format!("{} (expected frames per second, 0 < fps ≤ 1000)", a.fps),
            ));
        }
    }
    let mut dynamic = 0;
    for (i, c) in s.characters.iter().enumerate() {
        let field = format!("characters[{i}]");
        if let Some(m) = &c.motion {
            m.validate().map_err(|(sub, message)| invalid(&format!("{field}.motion.{sub}"), message))?;
            if s.animation.is_none() {
                return Err(invalid(
                    &format!("{field}.motion"),
                    "needs the scene's \"animation\": {\"frames\": N, \"fps\": R} (time is frame / fps)"
                        .into(),
                ));
            }
        }
        let Some(d) = &c.dynamics else { continue };
        dynamic += 1;
        let dyn_field = format!("{field}.dynamics");
        d.validate().map_err(|m| invalid(&dyn_field, m))?;
        if !e.dynamics {
            return Err(invalid(&dyn_field, "needs \"effects\": {\"dynamics\": true}".into()));
        }
        if s.animation.is_none() {
            return Err(invalid(
                &dyn_field,
                "needs the scene's \"animation\": {\"frames\": N, \"fps\": R} (the simulation's time step is 1 / fps)"
                    .into(),
            ));
        }
        let hair = loaded.hair_path(c);
        if matches!(hair.extension().and_then(|e| e.to_str()), Some("tfx" | "hair")) {
            return Err(invalid(
                &dyn_field,
                format!(
                    "{} holds explicit strands: dynamics simulate hair meshes (hair assets)",
                    hair.display()
                ),
            ));
        }
    }
    if characters && e.dynamics && dynamic == 0 {
        return Err(invalid(
            "effects.dynamics",
            "no character has a \"dynamics\" block (add \"dynamics\": {} to the characters to simulate)"
                .into(),
        ));
    }
    Ok(())
}
