//! Counter-based noise: a value is a pure function of (seed, channel, sample index), so the
//! same seed reproduces every glitch whatever order the plant evaluates them in.

/// Uniform noise in [−amplitude, amplitude] for sample `index` of `channel`.
pub fn uniform(seed: u64, channel: u64, index: u64, amplitude: f64) -> f64 {
    uniform_keyed(channel_key(seed, channel), index, amplitude)
}

/// The per-channel part of the hash, computed once per channel.
pub fn channel_key(seed: u64, channel: u64) -> u64 {
    seed ^ mix(channel.wrapping_add(0x9E37_79B9_7F4A_7C15))
}

/// [`uniform`] with the channel key precomputed.
pub fn uniform_keyed(key: u64, index: u64, amplitude: f64) -> f64 {
    if amplitude == 0.0 {
        return 0.0;
    }
    let z = mix(key ^ index.wrapping_mul(0xD1B5_4A32_D192_ED03));
    let unit = (z >> 11) as f64 * (1.0 / (1u64 << 53) as f64);
    amplitude * (2.0 * unit - 1.0)
}

/// SplitMix64 finaliser.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounded_deterministic_and_roughly_uniform() {
        let n = 100_000;
        let (mut sum, mut sq) = (0.0, 0.0);
        for k in 0..n {
            let x = uniform(7, 1, k, 2.0);
            assert!((-2.0..=2.0).contains(&x));
            assert_eq!(x, uniform(7, 1, k, 2.0));
            sum += x;
            sq += x * x;
        }
        let mean = sum / n as f64;
        let var = sq / n as f64 - mean * mean;
        // uniform(−2, 2): mean 0, variance 4/3; 5σ bounds for n = 1e5
        assert!(mean.abs() < 5.0 * (4.0f64 / 3.0 / n as f64).sqrt());
        assert!((var - 4.0 / 3.0).abs() < 0.02);
        assert_ne!(uniform(7, 1, 3, 1.0), uniform(8, 1, 3, 1.0));
        assert_ne!(uniform(7, 1, 3, 1.0), uniform(7, 2, 3, 1.0));
    }
}
