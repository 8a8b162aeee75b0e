//! Rewrites `sdk/cpp/generated/` from `wit/`.

fn main() -> anyhow::Result<()> {
    let dir = meshflow_c_bindgen::generated_dir();
    std::fs::create_dir_all(&dir)?;
    for (name, bytes) in meshflow_c_bindgen::generate()? {
        std::fs::write(dir.join(&name), bytes)?;
        println!("wrote {}", dir.join(&name).display());
    }
    Ok(())
}
