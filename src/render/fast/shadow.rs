//! Cast shadows in the fast arithmetic (camera-model.md §6): a shaded
//! point's tests ([`crate::render::shadows`]) run on its hit point and
//! normal, converted from the fast formats to I32F32 (exactly, within
//! I32F32's range), against the frame's primitives and lights in I32F32 —
//! the wide arithmetic's test, the same integer operations on every
//! board. A surface that takes a test is shaded point by point: it is
//! neither the plane in closed form nor a flat primitive whose sum is
//! kept ([`Mix32::fill`]). Without the `shadows` feature, none is taken.

use super::rays::Ray;
use super::Mix32;
#[cfg(feature = "shadows")]
use {
    super::arith::{sar64_low_lt32, smul_u, zip3},
    super::intersect::MixShape,
    super::rays::{AWAY, NO_HIT},
    super::Input,
    crate::render::prepare::{cam_prim, shading_light, CamPrim},
    crate::render::shading::{ShadingLight, V3},
    crate::render::shadows::Occluders,
    crate::scene::{MAX_LIGHTS, MAX_PRIMITIVES, Q},
};

/// A frame's shadow tests in the fast arithmetic.
#[cfg(feature = "shadows")]
#[derive(Clone, Debug)]
pub(super) struct Shadow {
    prims: heapless::Vec<CamPrim<Q>, MAX_PRIMITIVES>,
    lights: heapless::Vec<ShadingLight, MAX_LIGHTS>,
    pub(super) occluders: Occluders,
    /// The length unit's exponent (`U = 2^e` m) and the depth the fast
    /// frame's origin moved to (parallel rays; 0 otherwise).
    e: i32,
    z0: Q,
}

#[cfg(feature = "shadows")]
impl Shadow {
    /// The tests of the frame `f` of unit `2^e` moved to `z0`, if any
    /// surface takes one.
    #[inline(never)]
    pub(super) fn of(f: &Input, e: i32, z0: Q) -> Option<Shadow> {
        if !f.occluders.any() {
            return None;
        }
        let mut s = Shadow {
            prims: heapless::Vec::new(),
            lights: heapless::Vec::new(),
            occluders: f.occluders,
            e,
            z0,
        };
        for p in f.scene.primitives() {
            let _ = s.prims.push(cam_prim(f.scene, p, f.origin_scale, false, None));
        }
        for l in f.scene.lights() {
            let _ = s.lights.push(shading_light(f.scene, l));
        }
        Some(s)
    }

    /// The lights a point of primitive `prim` does not receive (bit `i`:
    /// light `i`): its point `pt` (S18 U) and unit normal towards the
    /// viewer `nt` (S30).
    #[inline(never)]
    pub(super) fn shadowed(&self, prim: usize, pt: [i32; 3], nt: [i32; 3]) -> u8 {
        // S18 U = 2^(e − 18) m: I32F32 bits shifted by 14 + e, saturated.
        let sh = 14 + self.e;
        let len = |v: i32| {
            let v = i128::from(v);
            let b = if sh >= 0 { v << sh } else { v >> -sh };
            Q::from_bits(b.clamp(i128::from(i64::MIN), i128::from(i64::MAX)) as i64)
        };
        let mut point: V3 = pt.map(len);
        point[2] = point[2].saturating_add(self.z0);
        let normal: V3 = nt.map(|n| Q::from_bits(i64::from(n) << 2));
        crate::render::shadows::shadowed::<Q>(&self.prims, &self.lights, &self.occluders, prim, point, normal)
    }
}

impl Mix32 {
    /// Whether any surface of the frame takes a shadow test.
    #[inline(always)]
    pub(super) fn any_shadow_test(&self) -> bool {
        #[cfg(feature = "shadows")]
        return self.shadow.is_some();
        #[cfg(not(feature = "shadows"))]
        false
    }

    /// The tests primitive `i` takes (0: none, or no shadows).
    #[inline(always)]
    pub(super) fn shadow_tests(&self, i: usize) -> u32 {
        #[cfg(feature = "shadows")]
        return self.shadow.as_ref().map_or(0, |s| s.occluders.tests_of(i));
        #[cfg(not(feature = "shadows"))]
        {
            let _ = i;
            0
        }
    }
}

impl Mix32 {
    /// The lights shadowed where ray `r` (in the field, its nearest hit
    /// known) meets its surface: the adaptive rule's share of a [`Key`]
    /// (0 without shadows or hit).
    ///
    /// [`Key`]: super::rays::Key
    #[cfg(feature = "shadows")]
    #[inline(never)]
    pub(super) fn shade_key<const PERSP: bool>(&self, r: &Ray) -> u8 {
        let Some(s) = &self.shadow else {
            return 0;
        };
        if r.t == NO_HIT || r.t == 0 {
            return 0;
        }
        let prim = (r.hit & !AWAY) as usize;
        let Some(p) = self.prims.get(prim) else {
            return 0;
        };
        let pt = r.hit_point::<PERSP, false>([0; 2]);
        let n = match p.shape {
            MixShape::Plane { n, .. } | MixShape::Disc { n, .. } | MixShape::Rect { n, .. } => n,
            MixShape::Sphere { c18, inv_r, .. } => zip3(pt, c18, |p, c| {
                sar64_low_lt32(smul_u(p.wrapping_sub(c), inv_r.0), inv_r.1)
            }),
        };
        let nt = if r.hit & AWAY != 0 {
            n.map(i32::saturating_neg)
        } else {
            n
        };
        s.shadowed(prim, pt, nt)
    }
}

impl Mix32 {
    /// Without the `shadows` feature no light is shadowed.
    #[cfg(not(feature = "shadows"))]
    #[inline(always)]
    pub(super) fn shade_key<const PERSP: bool>(&self, _: &Ray) -> u8 {
        0
    }
}
