//! A hash of what a scene renders, for telling parts of one render apart from another scene's
//! (`veach merge`): stable across runs, machines and builds, and blind to file names and JSON
//! layout (two files that load to the same scene hash the same).

use super::Scene;

/// FNV-1a, 64 bit (Fowler, Noll & Vo; the IETF draft "The FNV Non-Cryptographic Hash
/// Algorithm", §2): the standard library's hasher may change between Rust releases.
struct Fnv1a(u64);

impl Fnv1a {
    const OFFSET_BASIS: u64 = 0xcbf2_9ce4_8422_2325;
    const PRIME: u64 = 0x0000_0100_0000_01b3;

    fn bytes(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0 ^ b as u64).wrapping_mul(Self::PRIME);
        }
    }
}

impl std::fmt::Write for Fnv1a {
    fn write_str(&mut self, s: &str) -> std::fmt::Result {
        self.bytes(s.as_bytes());
        Ok(())
    }
}

impl Scene {
    /// The hash of the scene's triangles (their floats' bits), materials, lights and cameras (their
    /// `Debug` text: floats print the shortest text that reads back as the same value; they are
    /// few) and textures (the texels' bytes). Warnings are left out.
    pub fn content_hash(&self) -> u64 {
        use std::fmt::Write;
        let mut h = Fnv1a(Fnv1a::OFFSET_BASIS);
        for t in &self.triangles {
            let floats =
                t.p.iter()
                    .chain(&t.n)
                    .flat_map(|v| v.to_array())
                    .chain(t.uv.iter().flatten().flat_map(|v| v.to_array()));
            for f in floats {
                h.bytes(&f.to_bits().to_le_bytes());
            }
            h.bytes(&t.material.to_le_bytes());
        }
        let _ = write!(h, "{:?}{:?}{:?}", self.materials, self.lights, self.cameras);
        for t in &self.textures {
            let _ = write!(h, "{} {}x{} {:?} {:?} {}", t.name, t.width, t.height, t.wrap_s, t.wrap_t, t.nearest);
            h.bytes(bytemuck::cast_slice(&t.texels));
        }
        h.0
    }
}

#[cfg(test)]
mod tests {
    use super::Fnv1a;

    #[test]
    fn fnv1a_matches_the_published_test_vectors() {
        // From the FNV draft's test suite: "" and "a" and "foobar".
        for (text, hash) in [("", 0xcbf29ce484222325u64), ("a", 0xaf63dc4c8601ec8c), ("foobar", 0x85944171f73967e8)] {
            let mut h = Fnv1a(Fnv1a::OFFSET_BASIS);
            h.bytes(text.as_bytes());
            assert_eq!(h.0, hash, "{text:?}");
        }
    }
}
