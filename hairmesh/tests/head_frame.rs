//! The head frame estimated from the two test heads, as the files have them and turned to
//! other orientations, units and places; and the hairline it suggests.

mod common;

use common::testdata;
use glam::{DQuat, DVec3};
use hairmesh::head_frame::{HAIRLINE_OFFSET, HeadFrame};
use hairmesh::import::{load_faces, load_scalp};
use hairmesh::input::References;
use hairmesh::{ScalpMesh, ScalpSelector};

struct Head {
    file: &'static str,
    /// The scalp the README documents for it (a plane drawn by hand).
    selector: &'static str,
    /// Where the skull's centre is, by eye from the mesh, and how far off the estimate may be.
    skull: DVec3,
    tolerance: f64,
    /// How far (degrees) the cut at the neck or chest is from level: the estimated up leans as
    /// much once the head is off the file's axes (on them, snapping levels it).
    cut_tilt: f64,
}

/// Both heads face +Z with +Y up (LeePerrySmith in metres, Sintel in centimetres).
const HEADS: [Head; 2] = [
    Head {
        file: "heads/LeePerrySmith/LeePerrySmith.glb",
        selector: "above:0,0.8192,-0.5735,1.3435",
        skull: DVec3::new(0.0, 1.9, -0.2),
        tolerance: 0.5,
        cut_tilt: 5.0,
    },
    Head {
        file: "heads/sintel/sintel_bust.obj",
        selector: "above:0,0.9138,-0.4061,32",
        skull: DVec3::new(0.0, 34.0, -0.5),
        tolerance: 3.0,
        cut_tilt: 9.0,
    },
];

fn faces(head: &Head) -> ScalpMesh {
    load_faces(&testdata(head.file), References::InsideFolder).expect("the head loads")
}

fn degrees(a: DVec3, b: DVec3) -> f64 {
    a.angle_between(b).to_degrees()
}

#[test]
fn the_test_heads_face_front_with_up_up() {
    for head in &HEADS {
        let frame = HeadFrame::estimate(&faces(head)).expect("a frame");
        eprintln!("{}: {frame:?}", head.file);
        assert_eq!(frame.up, DVec3::Y, "{}", head.file);
        assert_eq!(frame.front, DVec3::Z, "{}", head.file);
        assert!(
            frame.centre.distance(head.skull) < head.tolerance,
            "{}: centre {} is not the skull's {}",
            head.file,
            frame.centre,
            head.skull
        );
    }
}

/// The same head turned off the axes (no snapping), scaled and moved: the frame turns, scales
/// and moves with it.
#[test]
fn a_turned_scaled_moved_head_carries_its_frame_along() {
    let turn = DQuat::from_euler(glam::EulerRot::YXZ, 0.7, 0.45, -0.3);
    let (scale, shift) = (37.0, DVec3::new(5.0, -120.0, 33.0));
    for head in &HEADS {
        let mesh = faces(head);
        let original = HeadFrame::estimate(&mesh).expect("a frame");
        let mut moved = mesh.clone();
        for p in &mut moved.positions {
            *p = turn * *p * scale + shift;
        }
        let frame = HeadFrame::estimate(&moved).expect("a frame");
        eprintln!("{}: turned {frame:?}", head.file);
        assert!(
            degrees(frame.up, turn * original.up) < head.cut_tilt,
            "{}: up {} vs {}",
            head.file,
            frame.up,
            turn * original.up
        );
        assert!(
            degrees(frame.front, turn * original.front) < head.cut_tilt,
            "{}: front {}",
            head.file,
            frame.front
        );
        let centre = turn * original.centre * scale + shift;
        assert!(frame.centre.distance(centre) < 0.05 * original.radius * scale, "{}", head.file);
        assert!((frame.radius / (original.radius * scale) - 1.0).abs() < 0.02, "{}", head.file);
    }
}

/// A Z-up export (Blender's axes) facing −Y: snapped to exactly those axes.
#[test]
fn a_z_up_head_gets_z_up() {
    let to_z_up = DQuat::from_rotation_x(std::f64::consts::FRAC_PI_2);
    for head in &HEADS {
        let mut mesh = faces(head);
        for p in &mut mesh.positions {
            *p = to_z_up * *p;
        }
        let frame = HeadFrame::estimate(&mesh).expect("a frame");
        assert_eq!(frame.up, DVec3::Z, "{}", head.file);
        assert_eq!(frame.front, DVec3::NEG_Y, "{}", head.file);
    }
}

/// The suggested hairline keeps (nearly) the scalp of the plane drawn by hand for each head.
#[test]
fn the_suggested_hairline_matches_the_hand_drawn_one() {
    for head in &HEADS {
        let mesh = faces(head);
        let frame = HeadFrame::estimate(&mesh).expect("a frame");
        let suggested = frame.hairline_faces(&mesh, HAIRLINE_OFFSET);
        let drawn = ScalpSelector::parse(head.selector).expect("a selector");
        let by_hand: Vec<u32> = (0..mesh.faces.len() as u32)
            .filter(|&f| drawn.keeps_centroid(mesh.centroid(&mesh.faces[f as usize])))
            .collect();
        let both: Vec<u32> = suggested.iter().copied().filter(|f| by_hand.binary_search(f).is_ok()).collect();
        // By area, not by face count: scans are denser where the detail is.
        let area = |list: &[u32]| {
            let mut m = mesh.clone();
            m.select(&ScalpSelector::Faces(list.to_vec()));
            m.area()
        };
        let (common, a, b) = (area(&both), area(&suggested), area(&by_hand));
        let agreement = common / (a + b - common);
        eprintln!(
            "{}: suggested area {a:.2}, by hand {b:.2}, intersection over union {agreement:.3}",
            head.file
        );
        assert!(agreement > 0.85, "{}: the suggested hairline agrees on {agreement:.3}", head.file);
        // And it converts: the `auto` selector is that hairline.
        let scalp = load_scalp(&testdata(head.file), &ScalpSelector::Auto).expect("auto converts");
        assert!(scalp.faces.len() * 10 > suggested.len() * 9, "{}", head.file);
    }
}
