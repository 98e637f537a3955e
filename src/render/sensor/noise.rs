//! Sensor noise (camera-model.md §9): the EMVA 1288 linear camera model,
//! from a counter-based generator, so that a pixel's noise depends on
//! (seed, frame id, pixel index, channel) only — not on the order pixels
//! are rendered in — and is the same on every target.
//!
//! **Generator** (docs/sensor.md): `mix` is the SplitMix64 finaliser
//! (`z ^= z >> 30; z *= 0xbf58476d1ce4e5b9; z ^= z >> 27;
//! z *= 0x94d049bb133111eb; z ^= z >> 31`, arithmetic mod 2⁶⁴). A frame's
//! key is `mix(seed + mix(frame_id + 1))`; channel `c` of pixel `p = j ·
//! width + i` draws `h = mix(key ^ (p << 4 | c << 2))`.
//! **Normal transform:** `z = ±√2 erfc⁻¹(t)` — the inverse of the normal
//! distribution — with `t = v / 2⁶³`, `v` the low 63 bits of `h` with the
//! lowest set (`t` in `[2⁻⁶³, 1)`, `|z|` up to 9.08), the sign `h`'s top
//! bit. The core takes `|z|` from [`HALF_NORMAL`], a cubic per half octave
//! of `t`, in integer arithmetic (the same bits on every target), within
//! [`Z_ERR`] of the exact value the reference computes in f64.
//! **Recorded value:** with `μ_y` the noise-free pixel value (DN, before
//! rounding), `K_sys = DN_max / μ_e,sat`, the noise in DN is
//! `z · sqrt(K_sys μ_y + (K_sys σ_d)²)` (shot noise of `μ_e = μ_y / K_sys`
//! electrons plus dark noise), and
//! `DN = clamp(floor(μ_y + noise + μ_y,dark + ½), 0, DN_max)`.

use crate::num::scalar::Scalar;
use crate::scene::{Noise, PixelFormat, Q};

/// The SplitMix64 finaliser's multipliers.
const MIX: [u64; 2] = [0xbf58_476d_1ce4_e5b9, 0x94d0_49bb_1331_11eb];

/// The SplitMix64 finaliser.
#[inline]
pub const fn mix(z: u64) -> u64 {
    mix_by(z, MIX)
}

/// [`mix`] with its multipliers `k` given ([`MIX`]): on the M3 and M4F read
/// from a [`Stage`] (two `LDRD`s, where the constants' four `MOVW`/`MOVT`
/// pairs took low-light 7 instructions a pixel more).
#[inline(always)]
const fn mix_by(mut z: u64, k: [u64; 2]) -> u64 {
    z = crate::num::wrapping_mul64(z ^ (z >> 30), k[0]);
    z = crate::num::wrapping_mul64(z ^ (z >> 27), k[1]);
    z ^ (z >> 31)
}

/// A frame's key.
pub(crate) const fn frame_key(seed: u64, frame_id: u32) -> u64 {
    mix(seed.wrapping_add(mix(frame_id as u64 + 1)))
}

/// `65 536 z` for channel `c` of pixel `p`: `±√2 erfc⁻¹(t)` of its hash
/// (the module's docs), rounded, within `65 536` [`Z_ERR`] of the exact
/// value (`|z| ≤ 9.08`).
#[inline]
pub fn normal_q16(key: u64, pixel: u32, channel: u8) -> i32 {
    normal_of_hash(mix(input(key, pixel, channel)))
}

/// The finaliser's input for channel `c` of pixel `p`: `key ^ (p << 4 |
/// c << 2)`.
#[inline(always)]
fn input(key: u64, pixel: u32, channel: u8) -> u64 {
    key ^ ((u64::from(pixel) << 4) | (u64::from(channel & 3) << 2))
}

/// [`normal_q16`]'s `65 536 z` of the hash `h`.
#[inline]
pub fn normal_of_hash(h: u64) -> i32 {
    // t = v 2^-63 in octave e (t in [2^-(e+1), 2^-e)) for v's leading zeros
    // e + 1 (1 to 63: v is odd and below 2^63); the bits below its leading
    // one are the mantissa's fraction, whose top bit is the half. `n`: v's
    // top 32 bits from its leading one — from the high word alone where
    // the 17 bits below the leading one lie in it (v ≥ 2^49: all but 2^-14
    // of the draws; a 64-bit count and shift cost the M3 ~5 instructions).
    let v = (h & (u64::MAX >> 1)) | 1;
    let hi = (v >> 32) as u32;
    let (lz, n) = if hi >= 1 << 17 {
        let lz = crate::num::clz32(hi);
        (lz, hi << lz)
    } else {
        let lz = crate::num::clz64(v);
        (lz, ((v << lz) >> 32) as u32)
    };
    // s in [0, 1) in units of 2^-16 (the 16 bits below the half's), and
    // the cubic in it by Horner; |z| < 9.1 in S27 → S16, rounded.
    let s = (n >> 14) as u16;
    let half = (n >> 30) & 1;
    let z = if crate::target::M0 {
        cubic_words(lz, half, s)
    } else {
        // The same value with each product the high word of one SMULL:
        // ⌊a s / 2^16⌋ = ⌊2a · 2^15 s / 2^32⌋, `a` carried doubled (every
        // Horner term is within ±2^27); the row's index masked, in bounds
        // without a test (lz is 1 to 63).
        let [c0, c1, c2, c3] = HALF_NORMAL_X2
            .get(((2 * lz + half) & 127) as usize)
            .copied()
            .unwrap_or([0; 4]);
        let s15 = i32::from(s) << 15;
        let hi = |a2: i32| ((i64::from(a2) * i64::from(s15)) >> 32) as i32;
        (c0 + hi(c1 + (hi(c2 + (hi(c3) << 1)) << 1))) >> 11
    };
    if h >> 63 == 0 {
        z
    } else {
        -z
    }
}

/// [`HALF_NORMAL`] for the products of [`normal_of_hash`] on the M3 and
/// M4F: `c1`, `c2`, `c3` doubled, `c0` with the rounding's `2¹⁰`, row `2e
/// + j` at `2(e + 1) + j` (rows 0, 1 unused).
// Indexing in a constant: an index out of range fails the build.
#[allow(clippy::indexing_slicing)]
const HALF_NORMAL_X2: [[i32; 4]; 128] = {
    let mut t = [[0i32; 4]; 128];
    let mut i = 0;
    while i < HALF_NORMAL.len() {
        let [c0, c1, c2, c3] = HALF_NORMAL[i];
        t[i + 2] = [c0 + (1 << 10), 2 * c1, 2 * c2, 2 * c3];
        i += 1;
    }
    t
};

/// [`normal_of_hash`]'s `65 536 |z|` on the M0 (no 32 × 32 → 64-bit
/// product) from `v`'s leading zeros `lz` (1 to 63), the half `half` and
/// the fraction `s`: [`HALF_NORMAL`]'s cubic by Horner with [`mul_frac`].
/// Compiled everywhere, so that the tests check it against the M3's form.
#[inline(always)]
fn cubic_words(lz: u32, half: u32, s: u16) -> i32 {
    let seg = (2 * lz.saturating_sub(1) + half) as usize;
    let [c0, c1, c2, c3] = HALF_NORMAL.get(seg).copied().unwrap_or([0; 4]);
    (c0 + mul_frac(c1 + mul_frac(c2 + mul_frac(c3, s), s), s) + (1 << 10)) >> 11
}

/// `⌊a s / 2¹⁶⌋` for a fraction `s / 2¹⁶` on the M0 (no 32 × 32 → 64-bit
/// product): from `a`'s two 16-bit halves, the same value.
#[inline(always)]
fn mul_frac(a: i32, s: u16) -> i32 {
    // a = hi 2^16 + lo, lo in [0, 2^16): ⌊a s / 2^16⌋ = hi s + ⌊lo s /
    // 2^16⌋ (hi s 2^16 is a multiple of 2^16).
    let (hi, lo) = (a >> 16, (a & 0xffff) as u32);
    hi * i32::from(s) + ((lo * u32::from(s)) >> 16) as i32
}

/// Largest `|z|` error of [`normal_q16`] against the exact `√2 erfc⁻¹(t)`:
/// the cubics' (about 2.6·10⁻⁵ at the ends of octave 0), the fraction's
/// 16 bits and the rounding to 2⁻¹⁶ (host-sim's `tests/sensor.rs` measures
/// it on every half octave).
pub const Z_ERR: f64 = 4e-5;

/// Largest `|z|` [`normal_q16`] draws: `√2 erfc⁻¹(2⁻⁶³)` = 9.0802, with
/// [`Z_ERR`].
pub(crate) const Z_MAX: f64 = 9.081;

/// The noise stage of a frame, in the renderer's scalar.
#[derive(Clone, Copy, Debug)]
pub struct Stage<S> {
    /// `K_sys` per channel, DN per electron.
    ksys: [S; 3],
    /// `(K_sys σ_d)²` per channel, DN².
    dark_var: [S; 3],
    /// `μ_y,dark` per channel plus ½ (the rounding), DN.
    offset: [S; 3],
    key: u64,
    /// [`MIX`], read from memory on every draw ([`mix_by`]); not on the
    /// M0, whose draws take [`MIX`] at compile time ([`Stage::normal`]).
    #[cfg(not(hilcam_m0))]
    mix: [u64; 2],
}

impl<S: Scalar> Stage<S> {
    /// The stage for `noise` on `format`, frame `frame_id`. The dark offset
    /// is in DN of the first channel; a channel with a larger full scale
    /// (RGB565 green) scales it like the exposure. In I32F32, saturating.
    pub fn new(noise: &Noise, format: PixelFormat, frame_id: u32) -> Stage<S> {
        let mut st = Stage {
            ksys: [S::ZERO; 3],
            dark_var: [S::ZERO; 3],
            offset: [S::HALF; 3],
            key: frame_key(noise.seed, frame_id),
            #[cfg(not(hilcam_m0))]
            mix: MIX,
        };
        for c in 0..3 {
            let [k, var, off] = channel_constants(noise, format.dn_max(c), format.dn_max(0));
            if let (Some(a), Some(b), Some(o)) =
                (st.ksys.get_mut(c), st.dark_var.get_mut(c), st.offset.get_mut(c))
            {
                *a = S::from_q(k);
                *b = S::from_q(var);
                *o = S::from_q(off);
            }
        }
        st
    }

    /// The stage of a scene's `noise` (if any) for frame `frame_id`;
    /// `None` without the `sensor` feature.
    pub fn for_frame(noise: Option<Noise>, format: PixelFormat, frame_id: u32) -> Option<Stage<S>> {
        match noise {
            Some(z) if cfg!(feature = "sensor") => Some(Stage::new(&z, format, frame_id)),
            _ => None,
        }
    }

    /// The recorded value of channel `c` of pixel `p` whose noise-free value
    /// is `mu` DN (before rounding), clamped to `[0, dn_max]`.
    #[inline]
    pub fn apply(&self, mu: S, pixel: u32, c: usize, dn_max: u32) -> u32 {
        self.apply_with(mu, pixel, c, dn_max, S::mul, |var, z| {
            var.sqrt().unwrap_or(S::ZERO).mul(z)
        })
    }

    /// The constants of channel `c` and the draw `z` of channel `c` of pixel
    /// `pixel`: what [`Stage::apply_with`] combines, for an arithmetic that
    /// combines them its own way (the fast one's [`crate::render::fast`]).
    #[inline(always)]
    pub(crate) fn draw(&self, pixel: u32, c: usize) -> Draw<S> {
        Draw {
            ksys: self.ksys.get(c).copied().unwrap_or(S::ZERO),
            dark_var: self.dark_var.get(c).copied().unwrap_or(S::ZERO),
            offset: self.offset.get(c).copied().unwrap_or(S::HALF),
            z: self.normal(pixel, c as u8),
        }
    }

    /// [`normal_q16`] of this frame's key: on the M3 and M4F with the
    /// multipliers read from memory ([`mix_by`]); the M0 splits their
    /// halves at compile time (read from memory they cost it 17
    /// instructions a draw).
    #[inline(always)]
    fn normal(&self, pixel: u32, channel: u8) -> i32 {
        #[cfg(not(hilcam_m0))]
        return normal_of_hash(mix_by(input(self.key, pixel, channel), self.mix));
        #[cfg(hilcam_m0)]
        return normal_q16(self.key, pixel, channel);
    }

    /// [`Stage::apply`] with `mul` giving `K_sys μ_y` (both ≥ 0) as
    /// [`Scalar::mul`] does, and `noise` the noise term `σ z` from `σ²` and
    /// the draw `z`: the fast arithmetic's own products and square root.
    /// Inlined into each caller: out of line (once a build has more than
    /// one), the call cost the noisy scene 14 M3 instructions a pixel.
    #[inline(always)]
    pub fn apply_with(
        &self,
        mu: S,
        pixel: u32,
        c: usize,
        dn_max: u32,
        mul: impl FnOnce(S, S) -> S,
        noise: impl FnOnce(S, S) -> S,
    ) -> u32 {
        let d = self.draw(pixel, c);
        let mu = if mu > S::ZERO { mu } else { S::ZERO };
        let z = S::from_q(Q::from_bits(i64::from(d.z) << 16));
        let v = mu.add(noise(mul(d.ksys, mu).add(d.dark_var), z)).add(d.offset);
        v.floor_int().clamp(0, i64::from(dn_max)) as u32
    }
}

/// One draw of [`Stage::draw`]: a channel's constants and the pixel's `z`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Draw<S> {
    /// `K_sys`, DN per electron (≥ 0).
    pub ksys: S,
    /// `(K_sys σ_d)²`, DN² (≥ 0).
    pub dark_var: S,
    /// `μ_y,dark + ½`, DN (≥ ½).
    pub offset: S,
    /// `65 536 z` ([`normal_q16`]: within ±595 100).
    pub z: i32,
}

/// `K_sys = dn/μ_e,sat`, `(K_sys σ_d)²` and `μ_y,dark · dn/dn0 + ½` of a
/// channel of full scale `dn` (`dn0` the first channel's), I32F32 from
/// integer arithmetic on the raw values, saturating.
#[inline(never)]
fn channel_constants(noise: &Noise, dn: u32, dn0: u32) -> [Q; 3] {
    let q = |v: u128| Q::from_bits(v.min(i64::MAX as u128) as i64);
    let raw = |v: Q| v.to_bits().max(0) as u128;
    let sat = raw(noise.saturation_e).max(1);
    let k = (u128::from(dn) << 64) / sat;
    let dark = k.saturating_mul(raw(noise.dark_noise_e)) >> 32;
    let var = dark
        .min(u128::from(u64::MAX))
        .saturating_mul(dark.min(u128::from(u64::MAX)))
        >> 32;
    let off = raw(noise.dark_offset_dn).saturating_mul(u128::from(dn)) / u128::from(dn0.max(1)) + (1 << 31);
    [q(k), q(var), q(off)]
}

/// `|z|` in S27 as cubics in `s` (coefficients of `1, s, s², s³`) for
/// each half octave of `t` ([`normal_q16`]): entry `2e + j` for `t = m
/// 2^−(e+1)`, `m` in `[1 + j/2, 1 + (j+1)/2)`, `s = 2(m − 1) − j`. Each
/// interpolates `√2 erfc⁻¹(t)` at the four Chebyshev nodes of its `s` in
/// `[0, 1]` (docs/sensor.md; host-sim's `tests/sensor.rs` computes them
/// again from the reference and checks these).
#[rustfmt::skip]
pub const HALF_NORMAL: [[i32; 4]; 126] = [
    [90525040, -52684152, 6409268, -1485566], // octave 0
    [42766420, -44223799, 2213866, -756884],
    [154394016, -40644677, 6554178, -1235105], // octave 1
    [119069969, -31139332, 3071039, -473854],
    [205903158, -34006853, 6127977, -1126055], // octave 2
    [176899664, -25034592, 2954818, -423220],
    [250008834, -29706063, 5677872, -1041866], // octave 3
    [224940114, -21388189, 2743095, -389413],
    [289085540, -26649540, 5282208, -972067], // octave 4
    [266747395, -18919260, 2544898, -361921],
    [324476801, -24342657, 4945056, -913191], // octave 5
    [304167192, -17114852, 2374225, -338894],
    [357025864, -22526381, 4657816, -862927], // octave 6
    [338295494, -15726380, 2229044, -319349],
    [387301126, -21050857, 4411147, -819533], // octave 7
    [369842951, -14617580, 2104962, -302566],
    [415706282, -19822857, 4197222, -781677], // octave 8
    [399299991, -13706987, 1997933, -288000],
    [442539750, -18781071, 4009871, -748337], // octave 9
    [427021193, -12942642, 1904692, -275230],
    [468029218, -17883376, 3844297, -718721], // octave 10
    [453272361, -12289706, 1822687, -263933],
    [492352920, -17099782, 3696761, -692211], // octave 11
    [478258598, -11723860, 1749934, -253857],
    [515653369, -16408306, 3564323, -668316], // octave 12
    [502141950, -11227568, 1684883, -244806],
    [538046569, -15792424, 3444652, -646646], // octave 13
    [525053002, -10787831, 1626308, -236622],
    [559628393, -15239458, 3335874, -626886], // octave 14
    [547098750, -10394794, 1573232, -229179],
    [580479128, -14739498, 3236470, -608776], // octave 15
    [568368128, -10040830, 1524867, -222374],
    [600666778, -14284677, 3145197, -592104], // octave 16
    [588935978, -9719940, 1480571, -216123],
    [620249532, -13868658, 3061025, -576693], // octave 17
    [608865969, -9427329, 1439816, -210356],
    [639277622, -13486277, 2983096, -562395], // octave 18
    [628212791, -9159117, 1402162, -205015],
    [657794762, -13133277, 2910687, -549084], // octave 19
    [647023814, -8912126, 1367243, -200051],
    [675839263, -12806116, 2843186, -536654], // octave 20
    [665340391, -8683725, 1334747, -195423],
    [693444922, -12501816, 2780071, -525013], // octave 21
    [683198861, -8471715, 1304411, -191094],
    [710641728, -12217858, 2720894, -514082], // octave 22
    [700631365, -8274243, 1276010, -187034],
    [727456431, -11952091, 2665266, -503793], // octave 23
    [717666482, -8089734, 1249349, -183218],
    [743913011, -11702670, 2612851, -494086], // octave 24
    [734329764, -7916843, 1224260, -179621],
    [760033063, -11467998, 2563355, -484908], // octave 25
    [750644156, -7754410, 1200596, -176224],
    [775836111, -11246690, 2516520, -476215], // octave 26
    [766630360, -7601428, 1178228, -173009],
    [791339877, -11037532, 2472118, -467965], // octave 27
    [782307121, -7457025, 1157044, -169961],
    [806560504, -10839462, 2429948, -460122], // octave 28
    [797691481, -7320432, 1136944, -167066],
    [821512745, -10651539, 2389831, -452655], // octave 29
    [812798985, -7190976, 1117839, -164311],
    [836210122, -10472933, 2351607, -445534], // octave 30
    [827643856, -7068060, 1099652, -161687],
    [850665070, -10302903, 2315133, -438734], // octave 31
    [842239151, -6951157, 1082310, -159182],
    [864889050, -10140790, 2280281, -432231], // octave 32
    [856596885, -6839794, 1065753, -156788],
    [878892652, -9986002, 2246934, -426005], // octave 33
    [870728147, -6733550, 1049921, -154498],
    [892685689, -9838007, 2214990, -420037], // octave 34
    [884643195, -6632048, 1034765, -152304],
    [906277270, -9696325, 2184352, -414310], // octave 35
    [898351540, -6534947, 1020239, -150199],
    [919675870, -9560523, 2154936, -408808], // octave 36
    [911862020, -6441940, 1006299, -148179],
    [932889389, -9430207, 2126661, -403516], // octave 37
    [925182865, -6352750, 992909, -146236],
    [945925207, -9305021, 2099458, -398422], // octave 38
    [938321753, -6267123, 980032, -144367],
    [958790228, -9184638, 2073260, -393515], // octave 39
    [951285862, -6184830, 967638, -142567],
    [971490924, -9068760, 2048008, -388782], // octave 40
    [964081910, -6105662, 955697, -140832],
    [984033370, -8957116, 2023646, -384213], // octave 41
    [976716200, -6029426, 944183, -139158],
    [996423276, -8849454, 2000124, -379801], // octave 42
    [989194653, -5955947, 933070, -137542],
    [1008666023, -8745545, 1977395, -375535], // octave 43
    [1001522839, -5885064, 922336, -135980],
    [1020766680, -8645177, 1955415, -371408], // octave 44
    [1013706006, -5816629, 911961, -134470],
    [1032730036, -8548154, 1934144, -367414], // octave 45
    [1025749104, -5750504, 901924, -133008],
    [1044560618, -8454296, 1913546, -363543], // octave 46
    [1037656810, -5686562, 892208, -131593],
    [1056262708, -8363435, 1893586, -359792], // octave 47
    [1049433548, -5624688, 882796, -130221],
    [1067840368, -8275416, 1874231, -356153], // octave 48
    [1061083507, -5564772, 873673, -128891],
    [1079297449, -8190094, 1855453, -352621], // octave 49
    [1072610658, -5506713, 864825, -127600],
    [1090637609, -8107335, 1837223, -349192], // octave 50
    [1084018772, -5450419, 856238, -126347],
    [1101864326, -8027014, 1819514, -345859], // octave 51
    [1095311429, -5395802, 847898, -125130],
    [1112980908, -7949014, 1802304, -342620], // octave 52
    [1106492037, -5342781, 839796, -123947],
    [1123990508, -7873225, 1785568, -339469], // octave 53
    [1117563836, -5291280, 831920, -122797],
    [1134896131, -7799547, 1769287, -336402], // octave 54
    [1128529919, -5241228, 824259, -121678],
    [1145700646, -7727882, 1753439, -333417], // octave 55
    [1139393231, -5192559, 816804, -120588],
    [1156406790, -7658142, 1738005, -330508], // octave 56
    [1150156587, -5145210, 809547, -119527],
    [1167017183, -7590242, 1722969, -327675], // octave 57
    [1160822674, -5099123, 802477, -118494],
    [1177534328, -7524103, 1708313, -324912], // octave 58
    [1171394061, -5054243, 795588, -117486],
    [1187960623, -7459650, 1694022, -322217], // octave 59
    [1181873210, -5010519, 788873, -116504],
    [1198298366, -7396814, 1680081, -319588], // octave 60
    [1192262474, -4967901, 782323, -115546],
    [1208549758, -7335528, 1666476, -317021], // octave 61
    [1202564110, -4926346, 775932, -114611],
    [1218716913, -7275729, 1653194, -314515], // octave 62
    [1212780284, -4885808, 769694, -113697],
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_has_unit_variance_and_zero_mean() {
        let key = frame_key(7, 3);
        let n = 200_000u32;
        let (mut s, mut s2) = (0f64, 0f64);
        for p in 0..n {
            let z = f64::from(normal_q16(key, p, 0)) / 65536.0;
            s += z;
            s2 += z * z;
        }
        let mean = s / f64::from(n);
        let var = s2 / f64::from(n) - mean * mean;
        assert!(mean.abs() < 0.01, "mean {mean}");
        assert!((var - 1.0).abs() < 0.01, "variance {var}");
    }

    /// The tails are the normal's: beyond 3σ and 4σ, 2.7·10⁻³ and
    /// 6.3·10⁻⁵ of the draws (the sum of twelve uniforms that the generator
    /// drew before has 2.0·10⁻³ and 1.7·10⁻⁵: Irwin–Hall's distribution,
    /// and fails both ranges).
    #[test]
    fn the_tails_are_the_normals() {
        let key = frame_key(11, 5);
        let n = 2_000_000u32;
        let (mut beyond3, mut beyond4) = (0u32, 0u32);
        for p in 0..n {
            let z = normal_q16(key, p, 0).unsigned_abs();
            beyond3 += u32::from(z > 3 << 16);
            beyond4 += u32::from(z > 4 << 16);
        }
        // Expected 5 400 (σ 73) and 127 (σ 11).
        assert!((5_100..5_700).contains(&beyond3), "beyond 3σ: {beyond3}");
        assert!((90..165).contains(&beyond4), "beyond 4σ: {beyond4}");
    }

    /// [`normal_of_hash`]'s doubled table and SMULL high words, and the
    /// M0's 16-bit products ([`cubic_words`]), give the value of the
    /// cubic's definition (`HALF_NORMAL`, Horner with exact floors), on
    /// every octave and both halves and on hashes of pixels.
    #[test]
    fn the_doubled_table_gives_the_cubics_value() {
        let floor16 = |a: i32, s: u16| ((i64::from(a) * i64::from(s)) >> 16) as i32;
        let by_definition = |h: u64| {
            let v = (h & (u64::MAX >> 1)) | 1;
            let lz = v.leading_zeros();
            let n = ((v << lz) >> 32) as u32;
            let [c0, c1, c2, c3] = HALF_NORMAL[(2 * (lz - 1) + ((n >> 30) & 1)) as usize];
            let s = (n >> 14) as u16;
            let z = (c0 + floor16(c1 + floor16(c2 + floor16(c3, s), s), s) + (1 << 10)) >> 11;
            // The M0's form (its 16-bit products) gives the same value.
            assert_eq!(cubic_words(lz, (n >> 30) & 1, s), z, "hash {h:#x}");
            if h >> 63 == 0 {
                z
            } else {
                -z
            }
        };
        let key = frame_key(3, 9);
        let mut checked = 0;
        for p in 0..200_000u32 {
            let h = mix(key ^ (u64::from(p) << 4));
            // The same fraction bits in every octave, and both signs.
            for e in [0u32, 1, 7, 14, 15, 16, 30, 31, 32, 47, 48, 62] {
                let g = (h >> (e + 1)) | (h & (1 << 63)) | ((p as u64 & 1) << 63);
                assert_eq!(normal_of_hash(g), by_definition(g), "hash {g:#x}");
                checked += 1;
            }
        }
        assert_eq!(checked, 2_400_000);
    }

    #[test]
    fn draws_depend_on_every_key_part() {
        let k = frame_key(1, 0);
        let z = normal_q16(k, 5, 0);
        assert_ne!(z, normal_q16(k, 6, 0));
        assert_ne!(z, normal_q16(k, 5, 1));
        assert_ne!(z, normal_q16(frame_key(1, 1), 5, 0));
        assert_ne!(z, normal_q16(frame_key(2, 0), 5, 0));
    }
}
