//! Batched rendering (`Sim::step_batch`, `Renderer::render_batch`): every view of a batch is
//! bit-identical to the same view rendered alone, whatever the batch's size and composition, and
//! bad batches are errors, not panics.

use crate::common;
use crate::goldens::{STREET, TEXTURES, parse};

use loomlab_sim::{Command, Renderer, Sim, SimError, WorldDesc};

fn worlds(n: u32) -> Vec<WorldDesc> {
    let mut out = vec![WorldDesc::default(), parse(TEXTURES), parse(STREET), WorldDesc::empty()];
    for w in &mut out {
        w.camera.n = n;
    }
    out
}

fn command(i: usize, k: usize) -> Command {
    Command {
        forward_mps: 0.5 + 0.25 * (i % 3) as f32,
        yaw_rate_rps: if (i + k / 7) % 2 == 0 { 0.2 } else { -0.1 },
        lateral_mps: 0.0,
    }
}

/// `views` simulators (the four test worlds in turn, different seeds) stepped alone and as one
/// batch: the outputs, frames included, are equal bit for bit.
fn check_batch_equals_single(n: u32, views: usize, steps: usize) {
    let worlds = worlds(n);
    let desc = |i: usize| &worlds[i % worlds.len()];
    let mut single: Vec<Sim> = (0..views)
        .map(|i| common::rendering_sim(desc(i), 3 + i as u64))
        .collect();
    let mut batched: Vec<Sim> = (0..views)
        .map(|i| Sim::new_physics_only(desc(i), 3 + i as u64).unwrap())
        .collect();
    let mut renderer = Renderer::new(n).unwrap();
    let first: Vec<_> = single.iter_mut().map(|s| s.observe().unwrap()).collect();
    let mut refs: Vec<&mut Sim> = batched.iter_mut().collect();
    assert_eq!(Sim::observe_batch(&mut refs, &mut renderer).unwrap(), first);
    for k in 0..steps {
        let commands: Vec<Command> = (0..views).map(|i| command(i, k)).collect();
        let alone: Vec<_> = single
            .iter_mut()
            .zip(&commands)
            .map(|(s, c)| s.step(c).unwrap())
            .collect();
        let mut refs: Vec<&mut Sim> = batched.iter_mut().collect();
        let together = Sim::step_batch(&mut refs, &commands, &mut renderer).unwrap();
        for (i, (a, b)) in alone.iter().zip(&together).enumerate() {
            assert_eq!(a.frame.len(), (n * n) as usize);
            assert!(
                a.frame.iter().zip(&b.frame).all(|(x, y)| x.to_bits() == y.to_bits()),
                "view {i} of {views} at step {k} differs from the same view rendered alone"
            );
            assert_eq!(a, b, "view {i} at step {k}");
            assert_eq!(batched[i].frame(), single[i].frame());
        }
    }
}

#[test]
fn a_batch_renders_every_view_bit_identical_to_rendering_it_alone() {
    check_batch_equals_single(64, 6, 12);
}

#[test]
fn batches_of_changing_size_and_frame_sizes_stay_bit_identical() {
    // 1, then 9 views (the target grows), at another frame size
    check_batch_equals_single(96, 1, 3);
    check_batch_equals_single(96, 9, 4);
    // 17 views: stepped and rendered in two groups, the second group's physics beside the first
    // group's rendering
    check_batch_equals_single(48, 17, 3);
}

#[test]
fn a_batch_larger_than_one_submission_is_split_and_stays_identical() {
    let ctx = loomlab_sim::GpuContext::new().unwrap();
    let mut renderer = Renderer::with_context(ctx.clone(), 32).unwrap();
    let max = renderer.max_batch();
    assert!((1..=loomlab_sim::render::MAX_BATCH as usize).contains(&max));
    let mut desc = WorldDesc::default();
    desc.camera.n = 32;
    let views = max + 3;
    let mut sims: Vec<Sim> = (0..views)
        .map(|i| Sim::new_physics_only(&desc, i as u64).unwrap())
        .collect();
    let commands = vec![Command::forward(1.0); views];
    let mut refs: Vec<&mut Sim> = sims.iter_mut().collect();
    let out = Sim::step_batch(&mut refs, &commands, &mut renderer).unwrap();
    assert_eq!(out.len(), views);
    let before = renderer.timings();
    assert!(before.submissions >= 2, "{before:?}");
    // the last view (in the second submission) equals the same simulator rendered alone
    let mut alone = Sim::with_context(&desc, (views - 1) as u64, ctx).unwrap();
    let a = alone.step(&Command::forward(1.0)).unwrap();
    assert_eq!(a, out[views - 1]);
}

#[test]
fn bad_batches_are_errors_and_move_nothing() {
    let ctx = loomlab_sim::GpuContext::new().unwrap();
    let mut renderer = Renderer::with_context(ctx, 32).unwrap();
    let mut desc = WorldDesc::default();
    desc.camera.n = 32;
    let mut a = Sim::new_physics_only(&desc, 1).unwrap();
    let mut other = desc.clone();
    other.camera.n = 48;
    let mut b = Sim::new_physics_only(&other, 1).unwrap();
    // a command per simulator
    let err = Sim::step_batch(&mut [&mut a], &[], &mut renderer).unwrap_err();
    assert!(err.to_string().contains("one per simulator"), "{err}");
    // every frame size the renderer's
    let err = Sim::step_batch(&mut [&mut a, &mut b], &[Command::default(); 2], &mut renderer).unwrap_err();
    assert!(matches!(err, SimError::SizeMismatch { world_n: 48, .. }), "{err}");
    let err = Sim::observe_batch(&mut [&mut b], &mut renderer).unwrap_err();
    assert!(matches!(err, SimError::SizeMismatch { .. }), "{err}");
    // a bad command anywhere: nothing moves
    let bad = Command::forward(f32::NAN);
    let mut c = Sim::new_physics_only(&desc, 2).unwrap();
    let err = Sim::step_batch(&mut [&mut a, &mut c], &[Command::forward(1.0), bad], &mut renderer).unwrap_err();
    assert!(!err.to_string().is_empty());
    assert_eq!((a.step_index(), c.step_index()), (0, 0));
    // an empty batch is fine
    assert!(Sim::step_batch(&mut [], &[], &mut renderer).unwrap().is_empty());
    // the two halves of a step check the same, and a group is collected with as many simulators
    let err = Sim::step_submit(&mut [&mut a], &[], &mut renderer).unwrap_err();
    assert!(err.to_string().contains("one per simulator"), "{err}");
    let steps = Sim::step_submit(&mut [&mut a, &mut c], &[Command::forward(1.0); 2], &mut renderer).unwrap();
    let err = Sim::step_collect(&mut [&mut a], &mut renderer, steps).unwrap_err();
    assert!(err.to_string().contains("one per submitted view"), "{err}");
    // render_batch wants one output per frame
    let mut outs = vec![Vec::new(); 2];
    let err = renderer.render_batch(&[], &mut outs).unwrap_err();
    assert!(err.to_string().contains("one per frame"), "{err}");
}

#[test]
fn captured_views_rendered_in_one_batch_equal_the_frames_of_each_step() {
    let desc = parse(TEXTURES);
    let n = desc.camera.n;
    let mut rendering = common::rendering_sim(&desc, 11);
    let mut physics = Sim::new_physics_only(&desc, 11).unwrap();
    let mut renderer = Renderer::new(n).unwrap();
    let cmd = Command::forward(0.8);
    let mut want = Vec::new();
    let mut views = Vec::new();
    for _ in 0..10 {
        want.push(rendering.step(&cmd).unwrap().frame);
        let out = physics.step(&cmd).unwrap();
        assert!(out.frame.is_empty());
        let view = physics.capture_view();
        assert_eq!(view.t_s(), out.t_s);
        views.push(view);
    }
    let descs: Vec<_> = views.iter().map(|v| v.desc()).collect();
    let mut got = vec![Vec::new(); descs.len()];
    renderer.render_batch(&descs, &mut got).unwrap();
    for (k, (a, b)) in want.iter().zip(&got).enumerate() {
        assert!(
            a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits()) && a.len() == b.len(),
            "frame {k}"
        );
    }
}

#[test]
fn batches_in_flight_together_each_equal_their_views_rendered_alone() {
    let desc = parse(STREET);
    let n = desc.camera.n;
    let mut physics = Sim::new_physics_only(&desc, 5).unwrap();
    let cmd = Command::forward(1.2);
    let views: Vec<_> = (0..9)
        .map(|_| {
            physics.step(&cmd).unwrap();
            physics.capture_view()
        })
        .collect();
    let descs: Vec<_> = views.iter().map(|v| v.desc()).collect();
    let mut alone_renderer = Renderer::new(n).unwrap();
    let alone: Vec<Vec<f32>> = descs
        .iter()
        .map(|d| {
            let mut out = Vec::new();
            alone_renderer.render(d, &mut out).unwrap();
            out
        })
        .collect();
    // three batches in flight at once; the second one is larger than any before it (the target
    // grows while the first is still being rendered)
    let mut renderer = Renderer::new(n).unwrap();
    let first = renderer.submit_batch(&descs[..2]).unwrap();
    let second = renderer.submit_batch(&descs[2..7]).unwrap();
    let third = renderer.submit_batch(&descs[7..]).unwrap();
    let mut got = vec![Vec::new(); descs.len()];
    // collected out of order
    renderer.collect_batch(second, &mut got[2..7]).unwrap();
    renderer.collect_batch(third, &mut got[7..]).unwrap();
    renderer.collect_batch(first, &mut got[..2]).unwrap();
    for (k, (a, b)) in alone.iter().zip(&got).enumerate() {
        assert_eq!(a.len(), (n * n) as usize);
        assert!(
            a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits()),
            "view {k}"
        );
    }
    assert_eq!(renderer.timings().submissions, 3);
    // bad calls are errors
    let err = renderer.submit_batch(&[]).unwrap_err();
    assert!(err.to_string().contains("1..="), "{err}");
    let too_many = vec![descs[0]; renderer.max_batch() + 1];
    assert!(renderer.submit_batch(&too_many).is_err());
    let pending = renderer.submit_batch(&descs[..2]).unwrap();
    let err = renderer.collect_batch(pending, &mut got[..1]).unwrap_err();
    assert!(err.to_string().contains("one per submitted view"), "{err}");
    let pending = renderer.submit_batch(&descs[..2]).unwrap();
    let err = alone_renderer.collect_batch(pending, &mut got[..2]).unwrap_err();
    assert!(err.to_string().contains("another renderer"), "{err}");
}
