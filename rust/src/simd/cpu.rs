//! Which CPU this is (vendor and family, from CPUID), for the tuning that
//! depends on more than the feature flags: how fast `pext` is
//! ([`super::periodic_avx2::fast_pext`]) and how the row kernels prefetch
//! ([`super::prefetch`]).

use std::arch::x86_64::__cpuid;

/// Vendor and family of a CPU.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Cpu {
    /// AMD, or Hygon (AMD's Zen 1 licensed).
    pub amd: bool,
    /// The family as AMD and Intel number it: base family, plus the
    /// extended family where the base is 0xF (AMD Zen 1-2: 0x17, Zen 3-4:
    /// 0x19, Zen 5: 0x1A).
    pub family: u32,
}

impl Cpu {
    /// The CPU of vendor string `vendor` and CPUID leaf 1 signature (`eax`).
    pub fn from_cpuid(vendor: &[u8], signature: u32) -> Cpu {
        let base = (signature >> 8) & 0xF;
        let family = if base == 0xF {
            base + ((signature >> 20) & 0xFF)
        } else {
            base
        };
        Cpu {
            amd: vendor == b"AuthenticAMD" || vendor == b"HygonGenuine",
            family,
        }
    }

    /// This machine's CPU. Read once.
    pub fn this() -> Cpu {
        static THIS: std::sync::OnceLock<Cpu> = std::sync::OnceLock::new();
        *THIS.get_or_init(|| {
            // SAFETY: CPUID leaves 0 and 1 exist on every x86-64 CPU. (`__cpuid`
            // is a safe function in newer toolchains, an unsafe one in 1.89.)
            #[allow(unused_unsafe)]
            let (vendor, signature) = unsafe { (__cpuid(0), __cpuid(1).eax) };
            let name: Vec<u8> = [vendor.ebx, vendor.edx, vendor.ecx]
                .iter()
                .flat_map(|r| r.to_le_bytes())
                .collect();
            Cpu::from_cpuid(&name, signature)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::Cpu;

    #[test]
    fn families_as_cpuid_reports_them() {
        // Zen 1 (EPYC 7601), Zen 2 (EPYC 7742), Hygon Dhyana, Zen 3 (EPYC
        // 7763), Zen 4 (EPYC 9654), Zen 5, Intel Skylake-SP and Haswell.
        let amd = b"AuthenticAMD";
        let cases: [(&[u8], u32, bool, u32); 8] = [
            (amd, 0x0080_0F12, true, 0x17),
            (amd, 0x0083_0F10, true, 0x17),
            (b"HygonGenuine", 0x0090_0F01, true, 0x18),
            (amd, 0x00A0_0F11, true, 0x19),
            (amd, 0x00A1_0F11, true, 0x19),
            (amd, 0x00B0_0F00, true, 0x1A),
            (b"GenuineIntel", 0x0005_0654, false, 6),
            (b"GenuineIntel", 0x0003_06F2, false, 6),
        ];
        for (vendor, signature, amd, family) in cases {
            assert_eq!(Cpu::from_cpuid(vendor, signature), Cpu { amd, family }, "{signature:#x}");
        }
    }
}
