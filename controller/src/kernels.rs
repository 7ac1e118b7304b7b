//! Hand-written Cortex-M4F kernels for the hot loop of the Jacobian rule, bit for bit the
//! Rust loops they replace (issue 18: the learning step's instruction budget).
//!
//! LLVM compiles the row loop of (8.15)/(8.21) to one `vldr`/`vstr` per entry (the row
//! lands in registers that are not consecutive, so no `vldm`/`vstm`), a bounds check per
//! neuron and a few register moves: about 46 instructions per row of 8. The kernel loads
//! and stores a row with one `vldm`/`vstm`, keeps `dv` and the average's 8 sums in
//! registers for the whole pass, and takes about 29 (38 for a row that is also averaged).
//! On the core a `vldm` of 8 registers takes 9 cycles against 16 for 8 `vldr`, so the
//! saving is in cycles as well as in the instructions QEMU counts.
//!
//! Same results: every value is computed by the same IEEE operations in the same order as
//! in [`crate::rules`] (`g = coeff * f`; `adv` summed from `0.0` in `d` order with
//! `vmla.f32`, which rounds the product and then the sum, as `adv += row[d] * dv[d]`
//! does; `s = (g * (dp_m - adv)) * inv`; `row[d] += s * dv[d]`; `acc[d] += al * row[d]`), so
//! the firmware's tables stay those of the host (the processor-in-the-loop run compares
//! them bit for bit). Only for `D = 8` (stage 1) on hard-float Arm; elsewhere the Rust
//! loops run.

/// The arguments of `trn_jacobian_rows_d8`, in one block (offsets in the assembly).
#[repr(C)]
struct RowPass {
    dv: [f32; 8],      // 0
    acc: [f32; 8],     // 32
    dpm: f32,          // 64
    coeff: f32,        // 68
    inv: f32,          // 72
    row0: *mut f32,    // 76: row m of neuron 0
    stride: u32,       // 80: bytes from one neuron's row m to the next's
    idx: *const u16,   // 84
    gamma: *const f32, // 88
    alpha: *const f32, // 92
    n_avg: u32,        // 96: ranks updated and averaged
    n_rest: u32,       // 100: ranks updated only (their indices follow)
}

/// One rank's row update, shared by the kernel's two loops: the row of neuron `idx[r]` (r3
/// steps through the indices) loaded, `g = coeff * gamma[r]` (r4 steps through the rates),
/// `adv = row . dv`, `s = g (dp_m - adv) inv`, `row += s dv`, stored; the row stays in
/// s8-s15 for the average.
macro_rules! row_update {
    () => {
        concat!(
            "ldrh r8, [r3], #2\n",
            "mla r8, r8, r2, r1\n",
            "vldm r8, {{s8-s15}}\n",
            "vldmia r4!, {{s28}}\n",
            "vmul.f32 s28, s25, s28\n",
            "vmov.f32 s29, s27\n",
            "vmla.f32 s29, s8, s16\n",
            "vmla.f32 s29, s9, s17\n",
            "vmla.f32 s29, s10, s18\n",
            "vmla.f32 s29, s11, s19\n",
            "vmla.f32 s29, s12, s20\n",
            "vmla.f32 s29, s13, s21\n",
            "vmla.f32 s29, s14, s22\n",
            "vmla.f32 s29, s15, s23\n",
            "vsub.f32 s29, s24, s29\n",
            "vmul.f32 s29, s28, s29\n",
            "vmul.f32 s29, s29, s26\n",
            "vmla.f32 s8, s29, s16\n",
            "vmla.f32 s9, s29, s17\n",
            "vmla.f32 s10, s29, s18\n",
            "vmla.f32 s11, s29, s19\n",
            "vmla.f32 s12, s29, s20\n",
            "vmla.f32 s13, s29, s21\n",
            "vmla.f32 s14, s29, s22\n",
            "vmla.f32 s15, s29, s23\n",
            "vstm r8, {{s8-s15}}\n",
        )
    };
}

core::arch::global_asm!(
    // the Cortex-M4F's FPU (single precision, 16 double registers): global assembly is
    // not told the target's features
    ".fpu fpv4-sp-d16",
    ".syntax unified",
    ".thumb",
    ".section .text.trn_jacobian_rows_d8,\"ax\",%progbits",
    ".global trn_jacobian_rows_d8",
    ".type trn_jacobian_rows_d8,%function",
    ".thumb_func",
    ".p2align 2",
    "trn_jacobian_rows_d8:",
    "push {{r4-r10, lr}}",
    "vpush {{s16-s31}}",
    "vldm r0, {{s16-s23}}",
    "add r1, r0, #32",
    "vldm r1, {{s0-s7}}",
    "vldr s24, [r0, #64]",
    "vldr s25, [r0, #68]",
    "vldr s26, [r0, #72]",
    "ldr r1, [r0, #76]",
    "ldr r2, [r0, #80]",
    "ldr r3, [r0, #84]",
    "ldr r4, [r0, #88]",
    "ldr r5, [r0, #92]",
    "ldr r6, [r0, #96]",
    "ldr r7, [r0, #100]",
    "movs r8, #0",
    "vmov s27, r8",
    "cmp r6, #0",
    "beq 2f",
    // ranks updated and averaged
    "1:",
    row_update!(),
    "vldmia r5!, {{s30}}",
    "vmla.f32 s0, s30, s8",
    "vmla.f32 s1, s30, s9",
    "vmla.f32 s2, s30, s10",
    "vmla.f32 s3, s30, s11",
    "vmla.f32 s4, s30, s12",
    "vmla.f32 s5, s30, s13",
    "vmla.f32 s6, s30, s14",
    "vmla.f32 s7, s30, s15",
    "subs r6, r6, #1",
    "bne 1b",
    "2:",
    "cmp r7, #0",
    "beq 4f",
    // ranks updated only
    "3:",
    row_update!(),
    "subs r7, r7, #1",
    "bne 3b",
    "4:",
    "add r1, r0, #32",
    "vstm r1, {{s0-s7}}",
    "vpop {{s16-s31}}",
    "pop {{r4-r10, pc}}",
    ".size trn_jacobian_rows_d8, . - trn_jacobian_rows_d8",
);

extern "C" {
    fn trn_jacobian_rows_d8(pass: *mut RowPass);
}

/// Row `m` of the Jacobian rule for the ranked neurons `ks` (rates `coeff * gamma`),
/// returning `sum alpha(r) row` over the first `als.len()` ranks (the updated rows), as the
/// loops of `rules::jacobian_rows` compute them. `None` (nothing done) unless `D = 8`,
/// there is a rate for every rank and a rank for every averaging weight, and every index is
/// a neuron of the table.
pub(crate) fn jacobian_rows<const N: usize, const D: usize, const M: usize>(
    a: &mut [[[f32; D]; M]; N],
    m: usize,
    (ks, gamma, als): (&[u16], &[f32], &[f32]),
    coeff: f32,
    dpm: f32,
    dv: &[f32; D],
    inv: f32,
) -> Option<[f32; D]> {
    if D != 8
        || N == 0
        || m >= M
        || gamma.len() != ks.len()
        || als.len() > ks.len()
        || !ks.iter().all(|&k| (k as usize) < N)
    {
        return None;
    }
    let mut pass = RowPass {
        dv: core::array::from_fn(|d| dv[d]),
        acc: [0.0; 8],
        dpm,
        coeff,
        inv,
        row0: a[0][m].as_mut_ptr(),
        stride: core::mem::size_of::<[[f32; D]; M]>() as u32,
        idx: ks.as_ptr(),
        gamma: gamma.as_ptr(),
        alpha: als.as_ptr(),
        n_avg: als.len() as u32,
        n_rest: (ks.len() - als.len()) as u32,
    };
    // SAFETY: the kernel reads `n_avg + n_rest = ks.len()` indices from `idx` and as many
    // rates from `gamma` (slices of that length, checked above), `n_avg` weights from
    // `alpha`, and reads and writes the 8 floats at `row0 + k * stride` for each index
    // `k < N` (checked): row `m < M` of neuron `k`, inside `a`, which it borrows mutably. It
    // writes `pass.acc` and touches nothing else (callee-saved registers restored, stack
    // balanced).
    unsafe { trn_jacobian_rows_d8(&mut pass) };
    Some(core::array::from_fn(|d| pass.acc[d]))
}
