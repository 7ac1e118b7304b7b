//! The guard seeded as a board seeds it: from its hardware RNG's draws
//! (`trn_node::seed_from_draws`), a good RNG giving a node that issues nonces (so a runner's
//! `--reset-tables` and `--tables FILE` work against it), a failed or stuck one a node that
//! refuses every guarded operation.

mod common;

use common::*;
use trn_node::{
    codes, seed_from_draws, ControllerNode, NodeConfig, Refusal, SeedFailure, SEED_DRAWS,
};
use trn_protocol::{ConfirmedSessionConfig, GuardOp, GuardRequest, Message};

/// A hardware RNG's words: a seeded xorshift32, never 0.
fn rng(seed: u32) -> impl Iterator<Item = Option<u32>> {
    let mut x = seed;
    std::iter::from_fn(move || {
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        Some(Some(x))
    })
}

fn nonce_or_refusal<C: trn_controller::Control + ?Sized>(
    n: &mut ControllerNode,
    b: &mut C,
    op: GuardOp,
) -> Result<u32, Vec<(u16, u32)>> {
    let out = send(n, b, GuardRequest { op }.into(), 0);
    out.iter()
        .find_map(|e| match e.msg {
            Message::GuardNonce(g) if g.op == op => Some(g.nonce),
            _ => None,
        })
        .ok_or_else(|| errors(&out))
}

#[test]
fn a_good_rng_seeds_a_node_that_reseeds_learned_tables_with_a_nonce() {
    let seed = seed_from_draws(rng(0x1234_5678)).unwrap();
    let words: Vec<u32> = rng(0x1234_5678).take(4).map(|w| w.unwrap()).collect();
    let expected: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
    assert_eq!(
        seed.to_vec(),
        expected,
        "the first four words, little-endian"
    );
    let (mut n, mut b) = booted_board(1, 3);
    n.seed_guard(seed);
    let other = session(77, false);
    let nonce = nonce_or_refusal(&mut n, &mut b, GuardOp::Reseed).expect("a nonce");
    let out = send(
        &mut n,
        &mut b,
        ConfirmedSessionConfig {
            config: other,
            nonce,
        }
        .into(),
        10,
    );
    assert!(errors(&out).is_empty(), "{out:?}");
    assert!(same(&b.ctrl, &learned(77, 0)), "re-seeded with 77");
    // two boards' RNGs give two generators: their nonces differ
    let (mut n2, mut c) = booted_board(1, 3);
    n2.seed_guard(seed);
    let (mut m, mut d) = booted_board(1, 3);
    m.seed_guard(seed_from_draws(rng(0x9ABC_DEF0)).unwrap());
    let a = nonce_or_refusal(&mut n2, &mut c, GuardOp::StoreErase).unwrap();
    let z = nonce_or_refusal(&mut m, &mut d, GuardOp::StoreErase).unwrap();
    assert_ne!(a, z);
}

#[test]
fn failed_and_repeated_draws_are_skipped() {
    // a seed error (None), a zero word and a repeat among the draws: skipped
    let draws = [Some(7), None, Some(0), Some(7), Some(8), Some(9), Some(10)];
    let seed = seed_from_draws(draws).unwrap();
    let words: Vec<u32> = seed
        .chunks_exact(4)
        .map(|c| u32::from_le_bytes(c.try_into().unwrap()))
        .collect();
    assert_eq!(words, vec![7, 8, 9, 10]);
}

#[test]
fn a_failed_or_stuck_rng_leaves_the_node_unseeded() {
    let dead = std::iter::repeat(None);
    assert_eq!(
        seed_from_draws(dead),
        Err(SeedFailure {
            failed: SEED_DRAWS as u8,
            repeated: 0
        })
    );
    let stuck = std::iter::repeat(Some(0xDEAD_BEEF));
    assert_eq!(
        seed_from_draws(stuck),
        Err(SeedFailure {
            failed: 0,
            repeated: SEED_DRAWS as u8 - 1
        })
    );
    // three good words, then nothing: no seed (never a partly filled one)
    let short = [Some(1), Some(2), Some(3)];
    assert_eq!(
        seed_from_draws(short),
        Err(SeedFailure {
            failed: 0,
            repeated: 0
        })
    );
    // a node left unseeded refuses: reason 5
    let mut b = learned(6, 2);
    let mut n = ControllerNode::new(NodeConfig::DEFAULT);
    assert_eq!(
        nonce_or_refusal(&mut n, &mut b, GuardOp::Reseed),
        Err(vec![(
            codes::GUARD_REFUSED,
            1 << 8 | Refusal::Unavailable as u32
        )])
    );
}
