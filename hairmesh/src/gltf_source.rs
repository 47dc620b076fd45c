//! A glTF file's JSON and binary chunk, made ready for the `gltf` crate.
//!
//! The crate refuses some files the Khronos validator accepts (`extras` that are not objects,
//! scenes without `nodes`, textures whose only source is an extension, animation channels
//! that target a pointer instead of a node, required extensions it does not know) and panics on
//! some broken GLB containers. A scalp needs only the scene graph, the meshes and their
//! accessors, so this module reads the container itself, checks what the schema says about the
//! parts it drops, and hands the crate only what the importer reads: no animations, textures,
//! images or samplers, materials reduced to their names (which `name:` scalp selectors use),
//! no `extras`.

use serde_json::{Map, Value};

/// GLB chunk types.
const CHUNK_JSON: u32 = 0x4E4F_534A;
const CHUNK_BIN: u32 = 0x004E_4942;

/// Required extensions the importer handles itself.
const HANDLED: &[&str] = &["KHR_mesh_quantization"];

/// Required extensions that change only what the importer ignores (materials, textures,
/// lights, animation): a scalp reads the same with or without them.
fn ignorable(extension: &str) -> bool {
    extension.starts_with("KHR_materials_")
        || extension.starts_with("KHR_texture_")
        || extension.starts_with("EXT_texture_")
        || matches!(extension, "KHR_lights_punctual" | "KHR_animation_pointer" | "EXT_lights_image_based")
}

/// The parsed file: the crate's document, the GLB binary chunk, and the extensions the file
/// uses.
pub(crate) struct GltfSource {
    pub document: gltf::Document,
    pub blob: Option<Vec<u8>>,
    pub used: Vec<String>,
}

/// Why a file cannot be used: a broken file, or one that needs an extension hairmesh lacks.
pub(crate) enum SourceError {
    Invalid(String),
    Unsupported(String),
}

fn invalid(message: impl Into<String>) -> SourceError {
    SourceError::Invalid(message.into())
}

fn word(bytes: &[u8], at: usize) -> Option<u32> {
    Some(u32::from_le_bytes(bytes.get(at..at + 4)?.try_into().ok()?))
}

/// Splits a GLB container into its JSON and first binary chunk (unknown chunks are skipped, as
/// the specification asks).
fn split_glb(bytes: &[u8]) -> Result<(&[u8], Option<Vec<u8>>), SourceError> {
    let header = |what: &str| invalid(format!("GLB header: {what}"));
    let version = word(bytes, 4).ok_or_else(|| header("shorter than 12 bytes"))?;
    if version != 2 {
        return Err(header(&format!("version {version} (glTF 2.0 files are GLB version 2)")));
    }
    let length = word(bytes, 8).ok_or_else(|| header("shorter than 12 bytes"))? as usize;
    if length > bytes.len() {
        return Err(header(&format!("declares {length} bytes but the file has {}", bytes.len())));
    }
    let (mut at, mut json, mut bin) = (12usize, None, None);
    let mut index = 0;
    while at < length {
        let chunk = |what: String| invalid(format!("GLB chunk {index}: {what}"));
        let (Some(len), Some(kind)) = (word(bytes, at), word(bytes, at + 4)) else {
            return Err(chunk("its header reaches past the end of the file".into()));
        };
        let len = len as usize;
        if !len.is_multiple_of(4) {
            return Err(chunk(format!("length {len} is not a multiple of 4")));
        }
        let start = at + 8;
        let end = start
            .checked_add(len)
            .filter(|&e| e <= length)
            .ok_or_else(|| chunk(format!("{len} bytes reach past the container's end ({length} bytes)")))?;
        match kind {
            CHUNK_JSON if index == 0 => json = Some(&bytes[start..end]),
            CHUNK_JSON => return Err(chunk("a second JSON chunk".into())),
            CHUNK_BIN if index == 0 => return Err(chunk("the first chunk must be JSON".into())),
            CHUNK_BIN if bin.is_none() && index == 1 => bin = Some(bytes[start..end].to_vec()),
            CHUNK_BIN => return Err(chunk("a binary chunk that is not the second chunk".into())),
            _ if index == 0 => return Err(chunk("the first chunk must be JSON".into())),
            _ => {}
        }
        at = end;
        index += 1;
    }
    let json = json.ok_or_else(|| invalid("GLB container without a JSON chunk"))?;
    Ok((json, bin))
}

/// `extras` may be any JSON value and are dropped; every `extensions` member must be an object
/// of objects (the schema's rule, checked here since the crate ignores extensions it does not
/// know).
fn clean(value: &mut Value, path: &mut Vec<String>) -> Result<(), SourceError> {
    match value {
        Value::Object(map) => {
            map.remove("extras");
            if let Some(extensions) = map.get("extensions") {
                let here = || format!("{}.extensions", path.join("."));
                let Value::Object(extensions) = extensions else {
                    return Err(invalid(format!("{}: must be a JSON object", here())));
                };
                if let Some((name, _)) = extensions.iter().find(|(_, v)| !v.is_object()) {
                    return Err(invalid(format!("{}.{name}: must be a JSON object", here())));
                }
            }
            for (key, v) in map.iter_mut() {
                path.push(key.clone());
                clean(v, path)?;
                path.pop();
            }
        }
        Value::Array(items) => {
            for (i, v) in items.iter_mut().enumerate() {
                path.push(i.to_string());
                clean(v, path)?;
                path.pop();
            }
        }
        _ => {}
    }
    Ok(())
}

fn strings(root: &Map<String, Value>, key: &str) -> Result<Vec<String>, SourceError> {
    match root.get(key) {
        None => Ok(Vec::new()),
        Some(Value::Array(items)) => items
            .iter()
            .map(|v| {
                v.as_str().map(str::to_owned).ok_or_else(|| invalid(format!("{key}: not a list of names")))
            })
            .collect(),
        Some(_) => Err(invalid(format!("{key}: not a list of names"))),
    }
}

/// The parts that are dropped must still be well-typed glTF (a number where a number
/// belongs): deserialized with the crate's types, which accept what the validator accepts once
/// a texture without `source` and an animation channel without `node` (both valid with
/// extensions) are given placeholders. Indices are not checked: nothing follows them.
fn check_dropped_parts(root: &Map<String, Value>) -> Result<(), SourceError> {
    fn typed<T: serde::de::DeserializeOwned>(key: &str, value: Option<Value>) -> Result<(), SourceError> {
        match value {
            None => Ok(()),
            Some(v) => {
                serde_json::from_value::<Vec<T>>(v).map(drop).map_err(|e| invalid(format!("{key}: {e}")))
            }
        }
    }
    typed::<gltf::json::Material>("materials", root.get("materials").cloned())?;
    typed::<gltf::json::Image>("images", root.get("images").cloned())?;
    typed::<gltf::json::texture::Sampler>("samplers", root.get("samplers").cloned())?;
    let mut textures = root.get("textures").cloned();
    for t in textures.iter_mut().filter_map(Value::as_array_mut).flatten().filter_map(Value::as_object_mut) {
        t.entry("source").or_insert(Value::from(0));
    }
    typed::<gltf::json::Texture>("textures", textures)?;
    let mut animations = root.get("animations").cloned();
    for a in animations.iter_mut().filter_map(Value::as_array_mut).flatten() {
        let channels = a.get_mut("channels").and_then(Value::as_array_mut).into_iter().flatten();
        for target in channels.filter_map(|c| c.get_mut("target")).filter_map(Value::as_object_mut) {
            target.entry("node").or_insert(Value::from(0));
        }
    }
    typed::<gltf::json::Animation>("animations", animations)
}

/// Keeps only what a scalp import reads (see the module's documentation).
fn reduce(root: &mut Map<String, Value>) {
    for key in ["animations", "textures", "images", "samplers", "extensionsRequired"] {
        root.remove(key);
    }
    if let Some(Value::Array(materials)) = root.get_mut("materials") {
        for m in materials.iter_mut() {
            let name = m.get("name").filter(|n| n.is_string()).cloned();
            *m = Value::Object(name.into_iter().map(|n| ("name".to_owned(), n)).collect());
        }
    }
    if let Some(Value::Array(scenes)) = root.get_mut("scenes") {
        for scene in scenes.iter_mut().filter_map(Value::as_object_mut) {
            scene.entry("nodes").or_insert_with(|| Value::Array(Vec::new()));
        }
    }
}

/// Parses a `.gltf` or `.glb` file's bytes.
pub(crate) fn parse(bytes: &[u8]) -> Result<GltfSource, SourceError> {
    let (json, blob) = if bytes.starts_with(b"glTF") { split_glb(bytes)? } else { (bytes, None) };
    let mut value: Value =
        serde_json::from_slice(json).map_err(|e| invalid(format!("not valid JSON: {e}")))?;
    clean(&mut value, &mut Vec::new())?;
    let Value::Object(root) = &mut value else { return Err(invalid("the JSON is not an object")) };
    let required = strings(root, "extensionsRequired")?;
    let used = strings(root, "extensionsUsed")?;
    if let Some(missing) = required.iter().find(|r| !used.contains(r)) {
        return Err(invalid(format!("extensionsRequired: {missing} is not in extensionsUsed")));
    }
    if let Some(unknown) = required.iter().find(|e| !HANDLED.contains(&e.as_str()) && !ignorable(e)) {
        return Err(SourceError::Unsupported(unknown.clone()));
    }
    check_dropped_parts(root)?;
    reduce(root);
    let root: gltf::json::Root =
        serde_json::from_value(value).map_err(|e| invalid(format!("not valid glTF: {e}")))?;
    Ok(GltfSource { document: gltf::Document::from_json_without_validation(root), blob, used })
}
