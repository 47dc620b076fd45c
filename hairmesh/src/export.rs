//! Hair out of hairkit: the strands the renderer generates from an asset, written as USD
//! (`.usda` text) for Unreal, Blender, Houdini and USD pipelines or as TressFX 4.0 (`.tfx`, for
//! engines with TressFX), and the hair mesh itself as glTF morph targets
//! ([`hair_mesh_as_scalp`]).
//!
//! The strands are the CPU reference generator's ([`HairAsset::generate_strand`]) at full detail
//! — the strands the GPU generates with LOD off, to f32 rounding — optionally fewer of them: each
//! bundle keeps a prefix of its blue-noise root set, so any count covers the scalp evenly.
//!
//! The USD layer holds one `Xform` (`/Groom`, with `GroomAPI` applied and the
//! `userProperties:groom_version_major/minor` Unreal's importer reads) over one `BasisCurves`
//! prim (`/Groom/Strands`): `type = "linear"` curves through the generated vertices,
//! `curveVertexCounts`, per-vertex `widths`, and the primvars Unreal's groom importer and
//! Blender's USD importer keep — `groom_id` (uniform int), `groom_group_id` (uniform int, one
//! group), `groom_guide` (uniform int, 0: every curve is a render strand), `groom_root_uv`
//! (uniform float2, the scalp's uv at the root), `groom_color` (vertex color3f) and
//! `displayColor`. The stage's `upAxis` and `metersPerUnit` say how to read the points.

use std::io::Write;

use glam::{DVec2, DVec3};

use crate::asset::HairAsset;
use crate::reference::{BundleLod, Strand};

/// The hair mesh as a scalp whose glTF morph targets are its layers above the roots: the form
/// `hairmesh convert --morph-layers` reads (Blender's shape keys), so a hair mesh can be edited
/// elsewhere and come back. Faces keep their quads; glTF stores them as triangle pairs, which
/// import joins again.
pub fn hair_mesh_as_scalp(hm: &crate::hair_mesh::HairMesh) -> crate::scalp::ScalpMesh {
    use crate::hair_mesh::BundleFace;
    crate::scalp::ScalpMesh {
        positions: hm.layers.first().cloned().unwrap_or_default(),
        uvs: hm.uvs.clone(),
        faces: hm
            .faces
            .iter()
            .map(|f| match f {
                BundleFace::Quad(q) => q.to_vec(),
                BundleFace::Triangle(t) => t.to_vec(),
            })
            .collect(),
        morph_layers: hm.layers.iter().skip(1).cloned().collect(),
        warnings: Vec::new(),
    }
}

/// What [`export_strands`] and [`write_usda`] are asked for.
#[derive(Clone, Debug, PartialEq)]
pub struct ExportOptions {
    /// Strands to export (`None`: every strand of the asset). Each bundle keeps the same share
    /// of its strands, at least one.
    pub strands: Option<u64>,
    /// Linear RGB of `groom_color` and `displayColor`.
    pub color: [f32; 3],
    /// The stage's `metersPerUnit`: 1 for an asset in metres.
    pub meters_per_unit: f64,
    /// The stage's `upAxis`.
    pub up_axis: UpAxis,
}

/// A USD stage's up axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum UpAxis {
    Y,
    Z,
}

/// A brown for hair without a colour of its own (render's default hair colour).
pub const DEFAULT_COLOR: [f32; 3] = [0.073, 0.024, 0.007];

impl Default for ExportOptions {
    fn default() -> Self {
        Self { strands: None, color: DEFAULT_COLOR, meters_per_unit: 1.0, up_axis: UpAxis::Y }
    }
}

/// One exported strand: its generated vertices and what the curve attributes need.
#[derive(Clone, Debug, PartialEq)]
pub struct ExportedStrand {
    pub strand: Strand,
    /// The scalp's uv at the root (the asset's uv texture).
    pub root_uv: DVec2,
}

/// The strands of `asset` to export, at full detail (LOD off): per bundle a prefix of its root
/// set, `options.strands` in all (about: each bundle rounds its share up).
pub fn export_strands(asset: &HairAsset, options: &ExportOptions) -> Vec<ExportedStrand> {
    let total = asset.total_strands().max(1);
    let share = options.strands.map_or(1.0, |n| (n as f64 / total as f64).clamp(0.0, 1.0));
    let mut out = Vec::new();
    for (b, info) in asset.bundles.iter().enumerate() {
        let b = b as u32;
        let keep =
            ((f64::from(info.strands) * share).ceil() as u32).clamp(1, info.strands.max(1)).min(info.strands);
        let lod = BundleLod::full_detail(keep, crate::reference::MAX_SEGMENTS_LOG2);
        for j in 0..keep {
            let strand = asset.generate_strand(b, j, &lod);
            let root = asset.root_parameter(b, j);
            let xy = asset.textures.layout.block_coord(b, root.x, root.y);
            let mut uv = [0.0; 2];
            asset.textures.uv.sample(DVec3::new(xy.x, xy.y, 0.5), &mut uv);
            out.push(ExportedStrand { strand, root_uv: DVec2::from_array(uv) });
        }
    }
    out
}

/// The points one exported file holds: counts checked before anything is written.
pub fn exported_points(strands: &[ExportedStrand]) -> u64 {
    strands.iter().map(|s| s.strand.positions.len() as u64).sum()
}

/// A float as USD text: shortest round-trip form, `nan`/`inf` refused upstream.
fn f(x: f64) -> String {
    let v = x as f32;
    if v == v.trunc() && v.abs() < 1e7 { format!("{v:.1}") } else { format!("{v}") }
}

/// Refuses, by name, a strand with a non-finite position or width: no file format here holds one.
fn check_finite(strands: &[ExportedStrand]) -> std::io::Result<()> {
    let broken = strands.iter().find(|s| {
        !s.strand.positions.iter().all(|p| p.is_finite()) || !s.strand.widths.iter().all(|w| w.is_finite())
    });
    match broken {
        Some(s) => Err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("strand {} of bundle {} has a non-finite vertex", s.strand.index, s.strand.bundle),
        )),
        None => Ok(()),
    }
}

/// Writes `strands` as a USD text layer (see the module docs) to `out`.
pub fn write_usda(
    out: &mut dyn Write,
    strands: &[ExportedStrand],
    options: &ExportOptions,
) -> std::io::Result<()> {
    let invalid = |what: String| std::io::Error::new(std::io::ErrorKind::InvalidData, what);
    if strands.is_empty() {
        return Err(invalid("no strands to export".into()));
    }
    check_finite(strands)?;
    let axis = match options.up_axis {
        UpAxis::Y => "Y",
        UpAxis::Z => "Z",
    };
    writeln!(out, "#usda 1.0")?;
    writeln!(out, "(")?;
    writeln!(out, "    defaultPrim = \"Groom\"")?;
    writeln!(out, "    doc = \"Hair strands exported by hairkit (hairmesh export)\"")?;
    writeln!(out, "    metersPerUnit = {}", f(options.meters_per_unit))?;
    writeln!(out, "    upAxis = \"{axis}\"")?;
    writeln!(out, ")")?;
    writeln!(out)?;
    writeln!(out, "def Xform \"Groom\" (")?;
    writeln!(out, "    prepend apiSchemas = [\"GroomAPI\"]")?;
    writeln!(out, ")")?;
    writeln!(out, "{{")?;
    writeln!(out, "    int userProperties:groom_version_major = 1")?;
    writeln!(out, "    int userProperties:groom_version_minor = 5")?;
    writeln!(out)?;
    writeln!(out, "    def BasisCurves \"Strands\"")?;
    writeln!(out, "    {{")?;
    writeln!(out, "        uniform token type = \"linear\"")?;
    writeln!(out, "        uniform token wrap = \"nonperiodic\"")?;
    // Large arrays are written a line at a time, each line built in one string.
    // Primvars carry their interpolation as the attribute's metadata.
    let array =
        |out: &mut dyn Write, head: &str, items: &mut dyn Iterator<Item = String>, interpolation: &str| {
            write!(out, "        {head} = [")?;
            let mut line = String::new();
            let mut first = true;
            for item in items {
                if !first {
                    line.push_str(", ");
                }
                first = false;
                line.push_str(&item);
                if line.len() > 4096 {
                    out.write_all(line.as_bytes())?;
                    line.clear();
                }
            }
            out.write_all(line.as_bytes())?;
            match interpolation {
                "" => writeln!(out, "]"),
                i => writeln!(out, "] (\n            interpolation = \"{i}\"\n        )"),
            }
        };
    array(
        out,
        "int[] curveVertexCounts",
        &mut strands.iter().map(|s| s.strand.positions.len().to_string()),
        "",
    )?;
    array(
        out,
        "point3f[] points",
        &mut strands
            .iter()
            .flat_map(|s| s.strand.positions.iter().map(|p| format!("({}, {}, {})", f(p.x), f(p.y), f(p.z)))),
        "",
    )?;
    array(
        out,
        "float[] widths",
        &mut strands.iter().flat_map(|s| s.strand.widths.iter().map(|w| f(*w))),
        "vertex",
    )?;
    array(out, "int[] primvars:groom_id", &mut (0..strands.len()).map(|i| i.to_string()), "uniform")?;
    array(out, "int[] primvars:groom_group_id", &mut strands.iter().map(|_| "0".to_owned()), "uniform")?;
    array(out, "int[] primvars:groom_guide", &mut strands.iter().map(|_| "0".to_owned()), "uniform")?;
    array(
        out,
        "float2[] primvars:groom_root_uv",
        &mut strands.iter().map(|s| format!("({}, {})", f(s.root_uv.x), f(s.root_uv.y))),
        "uniform",
    )?;
    let [r, g, b] = options.color.map(f64::from);
    let color = format!("({}, {}, {})", f(r), f(g), f(b));
    array(
        out,
        "color3f[] primvars:groom_color",
        &mut strands.iter().flat_map(|s| s.strand.positions.iter().map(|_| color.clone())),
        "vertex",
    )?;
    array(out, "color3f[] primvars:displayColor", &mut std::iter::once(color.clone()), "constant")?;
    writeln!(out, "    }}")?;
    writeln!(out, "}}")?;
    Ok(())
}

/// TressFX 4.x's header size and version.
const TFX_HEADER: u32 = 160;
const TFX_VERSION: f32 = 4.0;

/// Writes `strands` as a TressFX 4.0 `.tfx` file (the layout `crate::strands` reads): every
/// strand must have the same vertex count (TressFX's rule); positions with w = 0 at the root
/// (pinned) and 1 elsewhere, each strand's root uv and its root width as its thickness.
pub fn write_tfx(out: &mut dyn Write, strands: &[ExportedStrand]) -> std::io::Result<()> {
    let invalid = |what: String| std::io::Error::new(std::io::ErrorKind::InvalidData, what);
    let per_strand = strands.first().map_or(0, |s| s.strand.positions.len());
    if strands.is_empty() || per_strand < 2 {
        return Err(invalid("no strands to export".into()));
    }
    if let Some(s) = strands.iter().find(|s| s.strand.positions.len() != per_strand) {
        return Err(invalid(format!(
            "TressFX needs one vertex count for every strand: strand {} of bundle {} has {}, the first {per_strand}",
            s.strand.index,
            s.strand.bundle,
            s.strand.positions.len()
        )));
    }
    check_finite(strands)?;
    let count = u32::try_from(strands.len()).map_err(|_| invalid("too many strands for TressFX".into()))?;
    let vertices = u64::from(count) * per_strand as u64;
    let positions = u64::from(TFX_HEADER);
    let uvs = positions + vertices * 16;
    let thickness = uvs + u64::from(count) * 8;
    let end = thickness + u64::from(count) * 4;
    let offset =
        |o: u64| u32::try_from(o).map_err(|_| invalid(format!("{end} bytes: over TressFX's 4 GiB offsets")));
    let mut header = Vec::with_capacity(TFX_HEADER as usize);
    header.extend(TFX_VERSION.to_le_bytes());
    header.extend(count.to_le_bytes());
    header.extend((per_strand as u32).to_le_bytes());
    // Positions, per-strand uv, per-vertex uv (none), thickness, colours (none).
    for o in [offset(positions)?, offset(uvs)?, 0, offset(thickness)?, 0] {
        header.extend(o.to_le_bytes());
    }
    header.resize(TFX_HEADER as usize, 0);
    out.write_all(&header)?;
    let mut buffer = Vec::with_capacity(per_strand * 16);
    for s in strands {
        buffer.clear();
        for (k, p) in s.strand.positions.iter().enumerate() {
            let w = if k == 0 { 0.0f32 } else { 1.0 };
            for c in [p.x as f32, p.y as f32, p.z as f32, w] {
                buffer.extend(c.to_le_bytes());
            }
        }
        out.write_all(&buffer)?;
    }
    for s in strands {
        out.write_all(&(s.root_uv.x as f32).to_le_bytes())?;
        out.write_all(&(s.root_uv.y as f32).to_le_bytes())?;
    }
    for s in strands {
        out.write_all(&(s.strand.widths.first().copied().unwrap_or(0.0) as f32).to_le_bytes())?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn asset() -> HairAsset {
        let scalp = crate::procedural::head_cap(4, 16);
        let hm = crate::hair_mesh::HairMesh::extrude(
            &scalp,
            &crate::hair_mesh::ExtrudeParams { layers: 3, length: 0.1, ..Default::default() },
        )
        .expect("extrude");
        let params = crate::asset::AssetParams {
            strands: crate::asset::StrandCount::Total(600),
            ..crate::asset::AssetParams::default()
        };
        HairAsset::build(&hm, &params, crate::style::Style::default()).expect("asset")
    }

    #[test]
    fn fewer_strands_keep_every_bundle_and_its_first_roots() {
        let asset = asset();
        let all = export_strands(&asset, &ExportOptions::default());
        assert_eq!(all.len() as u64, asset.total_strands());
        assert!(all.iter().all(|s| s.strand.positions.len() == 33), "full detail: 33 vertices");
        let some = export_strands(&asset, &ExportOptions { strands: Some(100), ..ExportOptions::default() });
        assert!(some.len() >= 100 && some.len() < all.len(), "{} of {}", some.len(), all.len());
        for b in 0..asset.bundles.len() as u32 {
            let kept: Vec<u32> =
                some.iter().filter(|s| s.strand.bundle == b).map(|s| s.strand.index).collect();
            assert!(!kept.is_empty(), "bundle {b} keeps a strand");
            assert!(kept.iter().enumerate().all(|(i, j)| *j == i as u32), "bundle {b}: a prefix {kept:?}");
        }
        // The strands the reference generator makes for the GPU with LOD off, in its order.
        let lod_off = crate::reference::LodParams { enabled: false, ..Default::default() };
        let view = crate::reference::ViewParams {
            eye: DVec3::new(0.0, 1.6, 2.0),
            vertical_resolution: 720.0,
            projection: crate::reference::Projection::Perspective { fov_y: 0.8 },
        };
        let reference = asset.generate_reference(&view, &lod_off);
        assert!(all.iter().map(|s| &s.strand).eq(reference.iter()));
    }

    /// A `.tfx` export reads back through hairkit's TressFX loader bit for bit at f32.
    #[test]
    fn tressfx_export_round_trips_through_the_loader() {
        let asset = asset();
        let strands =
            export_strands(&asset, &ExportOptions { strands: Some(40), ..ExportOptions::default() });
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("hair.tfx");
        crate::atomic::write_file_atomic(&path, |w| write_tfx(w, &strands)).expect("write");
        let back = crate::strands::load_strands(&path).expect("read back");
        assert_eq!(back.format, "TressFX 4.0");
        assert_eq!(back.strand_points, vec![33; strands.len()]);
        let points: Vec<glam::Vec3> =
            strands.iter().flat_map(|s| s.strand.positions.iter().map(|p| p.as_vec3())).collect();
        assert_eq!(back.points, points);
        let uvs: Vec<[f32; 2]> = strands.iter().map(|s| [s.root_uv.x as f32, s.root_uv.y as f32]).collect();
        assert_eq!(back.root_uv, Some(uvs));
        let thickness: Vec<f32> = strands.iter().map(|s| s.strand.widths[0] as f32).collect();
        assert_eq!(back.thickness, Some(thickness));
        // Strands of different lengths are refused, naming one.
        let mut uneven = strands.clone();
        uneven[5].strand.positions.pop();
        let e = write_tfx(&mut Vec::new(), &uneven).expect_err("uneven");
        assert!(e.to_string().contains("one vertex count for every strand"), "{e}");
        let mut broken = strands.clone();
        broken[2].strand.widths[4] = f64::INFINITY;
        let e = write_tfx(&mut Vec::new(), &broken).expect_err("infinite width");
        assert!(e.to_string().contains("non-finite"), "{e}");
    }

    #[test]
    fn the_usda_text_holds_one_entry_per_curve_and_per_vertex() {
        let asset = asset();
        let strands =
            export_strands(&asset, &ExportOptions { strands: Some(50), ..ExportOptions::default() });
        let mut bytes = Vec::new();
        write_usda(&mut bytes, &strands, &ExportOptions::default()).expect("write");
        let text = String::from_utf8(bytes).expect("utf-8");
        let count = |name: &str, paren: bool| {
            let line =
                text.lines().find(|l| l.trim_start().starts_with(name)).unwrap_or_else(|| panic!("{name}"));
            let body = &line[line.find('[').expect("[") + 1..line.rfind(']').expect("]")];
            if paren { body.matches('(').count() } else { body.split(", ").count() }
        };
        let curves = strands.len();
        let points = exported_points(&strands) as usize;
        assert_eq!(count("int[] curveVertexCounts", false), curves);
        assert_eq!(count("point3f[] points", true), points);
        assert_eq!(count("float[] widths", false), points);
        assert_eq!(count("int[] primvars:groom_id", false), curves);
        assert_eq!(count("float2[] primvars:groom_root_uv", true), curves);
        assert_eq!(count("color3f[] primvars:groom_color", true), points);
        assert!(text.starts_with("#usda 1.0\n"));
        assert!(text.contains("prepend apiSchemas = [\"GroomAPI\"]"));
        // A strand with a non-finite vertex is refused, naming it.
        let mut broken = strands.clone();
        broken[3].strand.positions[2].x = f64::NAN;
        let e = write_usda(&mut Vec::new(), &broken, &ExportOptions::default()).expect_err("NaN");
        assert!(e.to_string().contains("non-finite"), "{e}");
    }
}
