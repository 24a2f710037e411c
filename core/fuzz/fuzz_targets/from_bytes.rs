//! Fuzzes the loader: any byte string must give `Ok` or `Err`, never a panic, and whatever loads
//! must evaluate without panicking. Run: `cd core/fuzz && cargo fuzz run from_bytes -s none`.
#![no_main]

use libfuzzer_sys::fuzz_target;
use sinew_core::SinewFile;
use sinew_core::network::load_mlp;

fuzz_target!(|data: &[u8]| {
    let Ok(file) = SinewFile::from_bytes(data) else { return };
    for section in file.sections() {
        let _ = (section.name(), section.dims(), section.elements(), section.f32s(), section.u32s());
    }
    let _ = file.metadata().iter().count();
    if let Ok(mlp) = load_mlp(&file, "mlp") {
        let input = [0.25f32; 64];
        let mut output = [0.0f32; 256];
        let mut scratch = [0.0f32; 1024];
        if mlp.inputs() <= input.len() && mlp.outputs() <= output.len() && mlp.scratch_len() <= scratch.len() {
            let _ = mlp.eval(&input[..mlp.inputs()], &mut output[..mlp.outputs()], &mut scratch);
        }
    }
});
