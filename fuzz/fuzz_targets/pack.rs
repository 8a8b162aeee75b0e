//! Any bytes as a packed mesh; half of the inputs resealed (magic, version, checksum) so
//! the fuzzer reaches the coded connectivity and geometry.
#![no_main]

use libfuzzer_sys::fuzz_target;
use meshflow_codec::pack;

fuzz_target!(|data: &[u8]| {
    let _ = pack::decode(data);
    if let Some((&reseal, rest)) = data.split_first() {
        if reseal & 1 == 1 {
            let mut bytes = b"MFM\x1a".to_vec();
            bytes.extend(pack::VERSION.to_le_bytes());
            bytes.extend([0; 16]);
            bytes.extend(rest);
            let sum = blake3::hash(&bytes[22..]);
            bytes[6..22].copy_from_slice(&sum.as_bytes()[..16]);
            if let Ok(mesh) = pack::decode(&bytes) {
                // Whatever decodes must pack and unpack to itself.
                let again = pack::decode(&pack::encode(&mesh).expect("decoded meshes are valid"));
                assert_eq!(again.expect("own output decodes"), mesh);
            }
        }
    }
});
