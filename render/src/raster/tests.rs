use glam::{Mat4, Vec3};

use super::screen_rect;

fn view_proj() -> Mat4 {
    let proj = Mat4::perspective_rh(60f32.to_radians(), 2.0, 0.01, 100.0);
    Mat4::from_scale(Vec3::new(1.0, -1.0, 1.0))
        * proj
        * Mat4::look_at_rh(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y)
}

#[test]
fn slots_fit_one_storage_buffer_with_their_coverage_and_threshold_words() {
    use super::{pixel_stride, slots_within};
    assert_eq!((pixel_stride(1), pixel_stride(2), pixel_stride(8)), (2, 4, 10));
    let pixels = 1280 * 720;
    assert_eq!(slots_within(16, pixels, 128 << 20), 16);
    // 9 words per pixel fit 64 MiB at 1280×720: 7 slots and their two words.
    let range = 64 << 20;
    assert_eq!(slots_within(16, pixels, range), 7);
    assert!(
        pixels * pixel_stride(7) * 8 <= u64::from(range) && pixels * pixel_stride(8) * 8 > u64::from(range)
    );
    // Too small for two slots and their two words: one slot (two words), or one anyway.
    assert_eq!(slots_within(8, pixels, (pixels * 3 * 8) as u32), 1);
    assert_eq!(slots_within(8, pixels, 8), 1);
}

#[test]
fn a_second_front_only_where_strand_lod_keeps_most_strands() {
    use crate::camera::{Camera, Character, character_inputs};
    use hairmesh::asset::{AssetParams, HairAsset, StrandCount};
    use hairmesh::reference::LodParams;
    use hairmesh::{ExtrudeParams, HairMesh};
    let scalp = hairmesh::procedural::head_cap(6, 24);
    let mesh = HairMesh::extrude(&scalp, &ExtrudeParams::default()).expect("the head cap extrudes");
    let params = AssetParams { strands: StrandCount::Total(20_000), ..AssetParams::default() };
    let asset =
        HairAsset::build(&mesh, &params, hairmesh::style::Style::default()).expect("the asset builds");
    let character = Character { hair: 0, transform: Mat4::IDENTITY };
    let pays = |distance: f32, lod: LodParams| {
        let camera = Camera {
            eye: Vec3::new(0.0, 1.6, distance),
            target: Vec3::new(0.0, 1.6, 0.0),
            fov_y: 45f32.to_radians(),
        };
        super::second_front_pays(&asset, &character_inputs(&camera, &character, 1280, 720, lod))
    };
    let strand_alpha = |a: f64| LodParams { enabled: true, strand_alpha: a, ..LodParams::default() };
    assert!(pays(0.6, strand_alpha(1.0)), "a close-up at full detail");
    assert!(pays(40.0, LodParams { enabled: false, ..LodParams::default() }), "LOD off: every strand");
    assert!(!pays(10.0, strand_alpha(64.0)), "a crowd's character whose bundles keep a few strands");
    let sparse_params = AssetParams { strands: StrandCount::Total(1000), ..AssetParams::default() };
    let sparse =
        HairAsset::build(&mesh, &sparse_params, hairmesh::style::Style::default()).expect("the asset builds");
    let camera = Camera { eye: Vec3::new(0.0, 1.6, 0.6), target: Vec3::new(0.0, 1.6, 0.0), fov_y: 0.8 };
    let inputs = character_inputs(&camera, &character, 1280, 720, strand_alpha(1.0));
    assert!(
        !super::second_front_pays(&sparse, &inputs),
        "bundles of a few strands each, even at full detail"
    );
}

#[test]
fn fused_frames_draw_a_second_eighth_between_the_front_and_the_rest() {
    use super::RasterPhase;
    use gen_gpu::SlotSubset::{All, Remainder, Sparse};
    let phase = |subset, part| RasterPhase { subset, part };
    assert_eq!(RasterPhase::sequence(false, 2), vec![phase(All, 0)]);
    assert_eq!(RasterPhase::sequence(true, 1), vec![phase(Sparse, 0), phase(Remainder, 1)]);
    assert_eq!(RasterPhase::sequence(true, 2), vec![phase(Sparse, 0), phase(Sparse, 1), phase(Remainder, 2)]);
    // At most two fronts: each bundle's sparse slots hold an eighth of its strands.
    assert_eq!(RasterPhase::sequence(true, 5).len(), 3);
    let culled: Vec<bool> =
        RasterPhase::sequence(true, 2).into_iter().map(RasterPhase::tile_culled).collect();
    assert_eq!(culled, [false, true, true], "every phase after the front meets the tiles");
    assert!(!RasterPhase::ALL.tile_culled());
}

#[test]
fn the_cleared_ranges_are_the_rects_pixel_words() {
    use super::{pixel_stride, rect_word_ranges};
    let (width, height) = (13u32, 7u32);
    for k in [1, 4] {
        let bytes = pixel_stride(k) * 8;
        for rect in [[2, 1, 9, 5], [0, 2, 13, 6], [0, 0, 13, 7], [12, 6, 13, 7], [3, 3, 3, 5], [5, 5, 4, 6]] {
            let mut cleared = vec![0u32; (width * height) as usize];
            for (offset, size) in rect_word_ranges(rect, width, k) {
                assert!(offset % bytes == 0 && size % bytes == 0 && size > 0, "{rect:?}: whole pixels");
                for pixel in offset / bytes..(offset + size) / bytes {
                    cleared[pixel as usize] += 1;
                }
            }
            let [x0, y0, x1, y1] = rect;
            for y in 0..height {
                for x in 0..width {
                    let inside = (x0..x1).contains(&x) && (y0..y1).contains(&y);
                    assert_eq!(
                        cleared[(y * width + x) as usize],
                        u32::from(inside),
                        "{rect:?} at ({x}, {y})"
                    );
                }
            }
        }
        // The whole width in one range.
        assert_eq!(rect_word_ranges([0, 2, 13, 6], width, k).len(), 1);
        assert_eq!(rect_word_ranges([1, 2, 13, 6], width, k).len(), 4);
    }
}

#[test]
fn the_rect_covers_the_projected_bounds_with_a_margin() {
    let unit = (Vec3::splat(-0.1), Vec3::splat(0.1));
    let [x0, y0, x1, y1] = screen_rect(view_proj(), 800, 400, [(Mat4::IDENTITY, unit)]);
    // The box projects to about ±10 px around the centre; the margin adds 66.
    assert!(x0 > 300 && x1 < 500 && y0 > 100 && y1 < 300, "{:?}", [x0, y0, x1, y1]);
    assert!(x0 < 400 - 66 && x1 > 400 + 66, "{:?}", [x0, y0, x1, y1]);
    // Moved off to the side: clamped to the frame.
    let side = Mat4::from_translation(Vec3::new(6.0, 0.0, 0.0));
    let [_, _, x1, _] = screen_rect(view_proj(), 800, 400, [(side, unit)]);
    assert_eq!(x1, 800);
}

#[test]
fn depth_clipping_is_skipped_only_for_boxes_inside_the_depth_range() {
    use super::DepthClipping::{self, Clip, Skip};
    // The eye at z = 5 looking down -z; near plane at z = 4.99, far plane at z = -95.
    let boxed = |lo: [f32; 3], hi: [f32; 3]| DepthClipping::for_bounds(view_proj(), (lo.into(), hi.into()));
    assert_eq!(boxed([-1.0; 3], [1.0; 3]), Skip);
    assert_eq!(boxed([-1.0, -1.0, 4.5], [1.0, 1.0, 4.98]), Skip, "1 cm in front of the eye");
    assert_eq!(boxed([-1.0, -1.0, 4.5], [1.0, 1.0, 4.995]), Clip, "through the near plane");
    assert_eq!(boxed([-1.0, -1.0, 5.5], [1.0, 1.0, 6.0]), Clip, "behind the eye");
    assert_eq!(boxed([-1.0, -1.0, -85.0], [1.0, 1.0, -80.0]), Skip);
    assert_eq!(boxed([-1.0, -1.0, -96.0], [1.0, 1.0, -90.0]), Clip, "through the far plane");
    // Far off to the side still counts as inside: x and y are clipped per pixel.
    assert_eq!(boxed([300.0, 0.0, -1.0], [301.0, 1.0, 0.0]), Skip);
    assert_eq!(boxed([1.0; 3], [-1.0; 3]), Clip, "an empty box");
    assert_eq!(boxed([f32::NAN; 3], [1.0; 3]), Clip);
    assert_eq!(boxed([-1.0; 3], [f32::INFINITY; 3]), Clip);
    // The object's transform moves the unit box onto the near plane.
    let onto = view_proj() * Mat4::from_translation(Vec3::new(0.0, 0.0, 4.5));
    assert_eq!(DepthClipping::for_bounds(onto, (Vec3::splat(-1.0), Vec3::splat(1.0))), Clip);
    // Seeded random boxes: wherever clipping is skipped, every point of the box the kernel
    // projects in f32 has 0 <= z <= w and w > 0.
    let mut state = 0x2545_f491_4f6c_dd1d_u64;
    let mut random = move || {
        state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        (state >> 40) as f32 / (1u64 << 24) as f32
    };
    let mut skipped = 0;
    for _ in 0..2_000 {
        let a = Vec3::new(random() - 0.5, random() - 0.5, 5.0 - 110.0 * random() * random())
            * Vec3::new(20.0, 20.0, 1.0);
        let extent = Vec3::new(random(), random(), random()) * 2.0;
        let (lo, hi) = (a, a + extent);
        if boxed(lo.into(), hi.into()) == Skip {
            skipped += 1;
            for _ in 0..16 {
                let p = lo + extent * Vec3::new(random(), random(), random());
                let clip = view_proj() * p.extend(1.0);
                assert!(clip.z >= 0.0 && clip.w - clip.z >= 0.0 && clip.w > 0.0, "{p} in {lo}..{hi}: {clip}");
            }
        }
    }
    assert!((500..1_900).contains(&skipped), "{skipped} of 2000 boxes skip the clipping");
}

#[test]
fn a_box_behind_the_camera_takes_the_whole_frame_and_no_box_none() {
    let around_eye = (Vec3::new(-1.0, -1.0, 4.0), Vec3::new(1.0, 1.0, 6.0));
    assert_eq!(screen_rect(view_proj(), 64, 32, [(Mat4::IDENTITY, around_eye)]), [0, 0, 64, 32]);
    assert_eq!(screen_rect(view_proj(), 64, 32, []), [0, 0, 0, 0]);
    let nan = (Vec3::splat(f32::NAN), Vec3::splat(f32::NAN));
    assert_eq!(screen_rect(view_proj(), 64, 32, [(Mat4::IDENTITY, nan)]), [0, 0, 64, 32]);
}
#[test]
fn slot_orders_stay_within_their_budget() {
    use super::order::{SLOT_ORDER_BUDGET_BYTES, SLOT_ORDER_BYTES_PER_SLOT, within_slot_order_budget};
    let per = SLOT_ORDER_BUDGET_BYTES / SLOT_ORDER_BYTES_PER_SLOT;
    // 40 % of the budget each: two fit, the third does not (nor a later small one: scene
    // order, so which characters get one does not depend on what comes after them).
    let c = per * 2 / 5;
    assert_eq!(within_slot_order_budget(&[c, c, c, 1]), vec![true, true, false, false]);
    assert_eq!(within_slot_order_budget(&[per]), vec![true]);
    assert_eq!(within_slot_order_budget(&[per + 1]), vec![false]);
    assert_eq!(within_slot_order_budget(&[u64::MAX, 1]), vec![false, false]);
    assert!(within_slot_order_budget(&[]).is_empty());
}

#[test]
fn the_slot_order_puts_marked_segments_first() {
    use crate::cpu::raster::slot_order;
    // No history: every eighth slot first, walking all of its segments; the others after.
    let order = slot_order(&[], 20, false);
    assert_eq!(order.front, vec![[0, u32::MAX], [8, u32::MAX], [16, u32::MAX]]);
    assert_eq!(order.rest.len(), 17);
    assert!(order.rest.iter().all(|e| e[0] % 8 != 0 && e[1] == 0));
    // Marks on three of 16 slots (one with every segment): more than 16 / 8, so they go
    // first alone, walking their marked segments; the rest walks the others, and a strand
    // marked whole has no rest entry.
    let mut marks = vec![0u32; 16];
    marks[3] = 0x0000_00ff;
    marks[5] = u32::MAX;
    marks[9] = 0x8000_0001;
    let order = slot_order(&marks, 16, true);
    assert_eq!(order.front, vec![[3, 0xff], [5, u32::MAX], [9, 0x8000_0001]]);
    assert_eq!(order.rest.len(), 15);
    assert!(order.rest.contains(&[3, 0xff]) && order.rest.contains(&[9, 0x8000_0001]));
    assert!(!order.rest.iter().any(|e| e[0] == 5));
    assert!(order.rest.contains(&[0, 0]));
    // One marked strand of 16 (fewer than 16 / 8): the sparse slots join the front whole,
    // and leave the rest.
    let mut marks = vec![0u32; 16];
    marks[3] = 0xf0;
    let order = slot_order(&marks, 16, true);
    assert_eq!(order.front, vec![[3, 0xf0], [0, u32::MAX], [8, u32::MAX]]);
    assert_eq!(order.rest.len(), 14);
    assert!(!order.rest.iter().any(|e| e[0] == 0 || e[0] == 8));
    // Marks without history count for nothing; every slot is drawn in some phase.
    assert_eq!(slot_order(&marks, 16, false), slot_order(&[], 16, false));
}
