//! `meshflow plugin new NAME --lang rust|cpp|python`: a plugin project that builds anywhere with
//! one command. The templates and, for C++, the SDK (header, generated bindings, the world's
//! type object) are compiled into this binary, so a C++ author needs only meshflow and clang.

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use clap::{Args, ValueEnum};

use crate::output::out;

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Lang {
    Rust,
    Cpp,
    Python,
}

#[derive(Args)]
pub struct NewArgs {
    /// The project's name: lowercase letters, digits and `-`, starting with a letter (the
    /// crate or the `.wasm` file is named after it).
    name: String,
    /// The language of the project.
    #[arg(long, value_enum)]
    lang: Lang,
    /// The folder to write (default: ./NAME); it must not exist or be empty.
    #[arg(long, value_name = "D")]
    dir: Option<PathBuf>,
    /// Rust: depend on the SDK at this folder (a meshflow checkout's `sdk/`).
    #[arg(long, value_name = "DIR", conflicts_with = "sdk_git")]
    sdk_path: Option<PathBuf>,
    /// Rust: depend on the SDK in this meshflow git repository (a hosted one, or a local
    /// clone as file:///…). Without this or --sdk-path: the repository this meshflow was
    /// built from.
    #[arg(long, value_name = "URL")]
    sdk_git: Option<String>,
}

/// A file of the checkout, compiled in.
macro_rules! checkout_file {
    ($path:literal) => {
        include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/", $path))
    };
}

const RUST_MANIFEST: &str = checkout_file!("examples/plugin-template/Cargo.toml");
const RUST_LOCK: &str = checkout_file!("examples/plugin-template/Cargo.lock");
const RUST_CONFIG: &str = checkout_file!("examples/plugin-template/.cargo/config.toml");
const RUST_LIB: &str = checkout_file!("examples/plugin-template/src/lib.rs");

const CPP_MAKEFILE: &str = checkout_file!("examples/plugin-template-cpp/Makefile");
const CPP_SOURCES: [(&str, &str); 5] = [
    ("src/services.cpp", checkout_file!("examples/plugin-template-cpp/src/services.cpp")),
    ("src/taubin.cpp", checkout_file!("examples/plugin-template-cpp/src/taubin.cpp")),
    ("src/taubin.hpp", checkout_file!("examples/plugin-template-cpp/src/taubin.hpp")),
    ("test/taubin_test.cpp", checkout_file!("examples/plugin-template-cpp/test/taubin_test.cpp")),
    ("test/patch.obj", checkout_file!("examples/plugin-template-cpp/test/patch.obj")),
];
const CPP_SDK: [(&str, &[u8]); 6] = [
    (
        "meshflow-sdk/include/meshflow.hpp",
        checkout_file!("sdk/cpp/include/meshflow.hpp").as_bytes(),
    ),
    (
        "meshflow-sdk/include/meshflow_native.h",
        checkout_file!("sdk/cpp/include/meshflow_native.h").as_bytes(),
    ),
    // The native test library (sdk/cpp/native), built for this machine by build.rs.
    (
        concat!("meshflow-sdk/lib/", env!("MESHFLOW_CPP_NATIVE_FILE")),
        include_bytes!(env!("MESHFLOW_CPP_NATIVE_LIB")),
    ),
    ("meshflow-sdk/generated/plugin.h", checkout_file!("sdk/cpp/generated/plugin.h").as_bytes()),
    ("meshflow-sdk/generated/plugin.c", checkout_file!("sdk/cpp/generated/plugin.c").as_bytes()),
    (
        "meshflow-sdk/generated/plugin_component_type.o",
        include_bytes!(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/sdk/cpp/generated/plugin_component_type.o"
        )),
    ),
];

const PY_FILES: [(&str, &str); 7] = [
    ("Makefile", checkout_file!("examples/plugin-template-python/Makefile")),
    ("app.py", checkout_file!("examples/plugin-template-python/app.py")),
    ("taubin.py", checkout_file!("examples/plugin-template-python/taubin.py")),
    ("test_app.py", checkout_file!("examples/plugin-template-python/test_app.py")),
    (".gitignore", checkout_file!("examples/plugin-template-python/.gitignore")),
    (
        "meshflow-sdk/meshflow_plugin/__init__.py",
        checkout_file!("sdk/python/meshflow_plugin/__init__.py"),
    ),
    ("wit/meshflow.wit", checkout_file!("wit/meshflow.wit")),
];

/// The Rust SDK of the checkout this binary was built from, when it is still there.
const BUILT_FROM_SDK: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/sdk");

pub fn run(args: NewArgs) -> anyhow::Result<()> {
    check_name(&args.name)?;
    let dir = args.dir.clone().unwrap_or_else(|| PathBuf::from(&args.name));
    if dir.exists() && std::fs::read_dir(&dir)?.next().is_some() {
        bail!("{} exists and is not empty: give another --dir", dir.display());
    }
    let files = match args.lang {
        Lang::Rust => rust_project(&args)?,
        Lang::Cpp => {
            if args.sdk_path.is_some() || args.sdk_git.is_some() {
                bail!(
                    "--sdk-path and --sdk-git are for Rust projects: a C++ project gets the \
                     SDK from this meshflow"
                );
            }
            cpp_project(&args.name)
        }
        Lang::Python => {
            if args.sdk_path.is_some() || args.sdk_git.is_some() {
                bail!(
                    "--sdk-path and --sdk-git are for Rust projects: a Python project gets the \
                     SDK from this meshflow"
                );
            }
            python_project(&args.name)
        }
    };
    for (name, bytes) in &files {
        let path = dir.join(name);
        std::fs::create_dir_all(path.parent().unwrap())
            .with_context(|| format!("creating {}", path.parent().unwrap().display()))?;
        std::fs::write(&path, bytes).with_context(|| format!("writing {}", path.display()))?;
    }
    let shown = dir.display();
    match args.lang {
        Lang::Rust => {
            let wasm = args.name.replace('-', "_");
            out!("wrote {shown}: a Rust plugin; build it with");
            out!("  cd {shown} && cargo build --release --target wasm32-wasip2");
            out!("  meshflow services --plugin target/wasm32-wasip2/release/{wasm}.wasm");
        }
        Lang::Cpp => {
            out!("wrote {shown}: a C++ plugin; build it with clang-19 and wasi-libc:");
            out!("  cd {shown} && make        # MESHFLOW=/path/to/meshflow if not on PATH");
            out!("  make test                 # test/*.cpp natively, with the host's edit checks");
            out!("  meshflow services --plugin build/{}.wasm", args.name);
        }
        Lang::Python => {
            out!(
                "wrote {shown}: a Python plugin; build it with componentize-py (make makes a venv):"
            );
            out!("  cd {shown} && make");
            out!("  meshflow services --plugin {}.wasm", args.name);
        }
    }
    Ok(())
}

fn check_name(name: &str) -> anyhow::Result<()> {
    let mut chars = name.chars();
    let good = chars.next().is_some_and(|c| c.is_ascii_lowercase())
        && chars.all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '-')
        && !name.ends_with('-');
    if !good {
        bail!(
            "`{name}` is not a plugin name: use lowercase letters, digits and `-`, starting \
             with a letter (e.g. `my-filters`)"
        );
    }
    Ok(())
}

type Files = Vec<(String, Vec<u8>)>;

fn text(name: &str, text: impl Into<String>) -> (String, Vec<u8>) {
    (name.to_owned(), text.into().into_bytes())
}

fn rust_project(args: &NewArgs) -> anyhow::Result<Files> {
    let dependency = match (&args.sdk_path, &args.sdk_git) {
        (Some(path), _) => format!("{{ path = {} }}", toml_string(&sdk_dir(path)?)),
        (None, Some(url)) => format!("{{ git = {} }}", toml_string(url)),
        (None, None) if Path::new(BUILT_FROM_SDK).join("Cargo.toml").is_file() => {
            let _ = {
                use std::io::Write;
                writeln!(
                    std::io::stderr(),
                    "note: the SDK is the checkout this meshflow was built from ({BUILT_FROM_SDK}); \
                     --sdk-git URL or --sdk-path DIR choose another"
                )
            };
            format!("{{ path = {} }}", toml_string(BUILT_FROM_SDK))
        }
        (None, None) => bail!(
            "say where the Rust SDK comes from: --sdk-git URL (meshflow's git repository) or \
             --sdk-path DIR (a checkout's sdk/ folder)"
        ),
    };
    // The template's manifest, minus the patch that points it at the checkout's SDK.
    let manifest = RUST_MANIFEST
        .split("\n# Inside the meshflow repository")
        .next()
        .unwrap()
        .replace("name = \"surface-tools\"", &format!("name = {}", toml_string(&args.name)))
        .replace(
            "meshflow-plugin-sdk = { git = \"file:///home/me/src/meshflow\" }",
            &format!("meshflow-plugin-sdk = {dependency}"),
        );
    debug_assert!(manifest.contains(&dependency));
    // The versions meshflow is tested with; cargo updates the SDK's entry to its source.
    let lock = RUST_LOCK
        .replace("name = \"surface-tools\"", &format!("name = {}", toml_string(&args.name)));
    let wasm = args.name.replace('-', "_");
    Ok(vec![
        text("Cargo.toml", manifest),
        text("Cargo.lock", lock),
        text(".cargo/config.toml", RUST_CONFIG),
        text("src/lib.rs", RUST_LIB),
        text(".gitignore", "/target\n"),
        text("README.md", rust_readme(&args.name, &wasm)),
    ])
}

/// The SDK crate's folder, absolute, after checking that it is one.
fn sdk_dir(path: &Path) -> anyhow::Result<String> {
    let dir = std::fs::canonicalize(path)
        .with_context(|| format!("--sdk-path {}: no such folder", path.display()))?;
    let manifest = std::fs::read_to_string(dir.join("Cargo.toml")).unwrap_or_default();
    if !manifest.contains("name = \"meshflow-plugin-sdk\"") {
        bail!(
            "--sdk-path {}: not the SDK crate (no Cargo.toml naming meshflow-plugin-sdk); give \
             a meshflow checkout's sdk/ folder",
            path.display()
        );
    }
    Ok(dir.display().to_string())
}

fn toml_string(s: &str) -> String {
    // A TOML basic string is a JSON string for everything a path or URL holds.
    serde_json::to_string(s).unwrap()
}

fn cpp_project(name: &str) -> Files {
    let makefile = CPP_MAKEFILE
        .replace("NAME     ?= taubin", &format!("NAME     ?= {name}"))
        .replace("SDK      ?= ../../sdk/cpp", "SDK      ?= meshflow-sdk");
    let mut files = vec![
        text("Makefile", makefile),
        text(".gitignore", "/build\n"),
        text("README.md", cpp_readme(name)),
    ];
    files.extend(CPP_SOURCES.iter().map(|(path, source)| text(path, *source)));
    files.extend(CPP_SDK.iter().map(|(path, bytes)| (path.to_string(), bytes.to_vec())));
    files
}

fn python_project(name: &str) -> Files {
    let mut files: Files = PY_FILES
        .iter()
        .map(|(path, source)| {
            let source = match *path {
                "Makefile" => source
                    .replace("MESHFLOW_WIT ?= ../../wit", "MESHFLOW_WIT ?= wit")
                    .replace("MESHFLOW_SDK ?= ../../sdk/python", "MESHFLOW_SDK ?= meshflow-sdk")
                    .replace("OUT ?= py.wasm", &format!("OUT ?= {name}.wasm")),
                ".gitignore" => source.replace("py.wasm", &format!("{name}.wasm")),
                _ => source.to_string(),
            };
            text(path, source)
        })
        .collect();
    files.push(text("README.md", python_readme(name)));
    files
}

fn python_readme(name: &str) -> String {
    format!(
        "# {name}: a meshflow plugin in Python

Written by `meshflow plugin new {name} --lang python`: Taubin smoothing
(`taubin-smoothing-py`) and a check (`mean-valence-py`) in `app.py` and `taubin.py`, on
meshflow's Python plugin SDK in `meshflow-sdk/meshflow_plugin/`, built against meshflow's
WIT in `wit/` by componentize-py. Rename the services in `app.py` before you publish your
own. Inside the sandbox there is CPython and its standard library: no numpy.

```sh
make                                     # a venv (.venv) with componentize-py, then {name}.wasm
make test                                # the services in plain CPython (pytest)
meshflow services --plugin {name}.wasm
meshflow apply taubin-smoothing-py bunny.obj -o smooth.ply --param iterations=20 \\
    --plugin {name}.wasm
meshflow plugin upload --host http://server:7070 {name}.wasm
```

The component holds CPython (about 18 MB); a host compiles it once on first load (tens of
seconds) and caches the result.

{LIMITS}
meshflow's `docs/python.md` describes the SDK.
"
    )
}

const LIMITS: &str = "\
Every run is sandboxed (no files, sockets, clock or entropy: take randomness from a `seed`
parameter) and limited: a deadline of 60 s of wall-clock time per run by default
(`--run-deadline SECONDS`, up to 3600, on `meshflow apply`, `check`, `run`, `host`, `up`),
and a memory cap of 2 GiB of linear memory per run by default (`--memory-cap MIB`, up to
4096, on the same commands; a 1M-vertex mesh with adjacency needs about 200 MB). Service
names must differ from the built-ins' (`meshflow services` lists them): a host refuses
such an upload, and `--plugin` says on stderr when yours hides one.
";

fn rust_readme(name: &str, wasm: &str) -> String {
    format!(
        "# {name}: a meshflow plugin in Rust

Written by `meshflow plugin new {name} --lang rust`: a filter (`scale-about-centroid`) and a
check (`total-area`) in `src/lib.rs`, on the SDK crate `meshflow-plugin-sdk` (its source is
in `Cargo.toml`).

```sh
rustup target add wasm32-wasip2          # once
cargo test                               # the algorithms, natively
cargo build --release --target wasm32-wasip2
meshflow services --plugin target/wasm32-wasip2/release/{wasm}.wasm
meshflow apply scale-about-centroid bunny.obj -o big.ply --param factor=3 \\
    --plugin target/wasm32-wasip2/release/{wasm}.wasm
meshflow plugin upload --host http://server:7070 target/wasm32-wasip2/release/{wasm}.wasm
```

{LIMITS}
meshflow's `examples/plugin-template/README.md` walks through the code.
"
    )
}

fn cpp_readme(name: &str) -> String {
    format!(
        "# {name}: a meshflow plugin in C++

Written by `meshflow plugin new {name} --lang cpp`: Taubin smoothing (`taubin-smoothing-cpp`)
in `src/`, on meshflow's C++ SDK in `meshflow-sdk/` (`include/meshflow.hpp`, and the C
bindings generated from meshflow's WIT). Rename the service in `src/services.cpp` before
you publish your own.

```sh
apt-get install clang-19 lld-19 wasi-libc libc++-19-dev-wasm32 libclang-rt-19-dev-wasm32 make
make                                     # -> build/{name}.wasm (MESHFLOW=/path/to/meshflow)
apt-get install libc++-19-dev libc++abi-19-dev libclang-rt-19-dev   # for make test
make test                                # test/*.cpp natively, on test/patch.obj
make test TEST_MESH=bunny.obj            # ... on another mesh file
meshflow services --plugin build/{name}.wasm
meshflow apply taubin-smoothing-cpp bunny.obj -o smooth.ply --param iterations=20 \\
    --plugin build/{name}.wasm
meshflow plugin upload --host http://server:7070 build/{name}.wasm
```

`make` compiles for wasm32-wasi as a reactor, links the bindings and the world's type
object, and runs `meshflow plugin componentize`, which adds the WASI adapter and loads the
result as a host loads an upload.

`make test` builds the same services and each `test/*.cpp` for this machine with
`-DMESHFLOW_NATIVE` (clang++-19 with libc++, address and undefined-behaviour sanitizers),
linked against `meshflow-sdk/lib/libmeshflow_native.so`: the host's own recording store,
parameter rules and mesh readers. `meshflow::native::run(\"taubin-smoothing-cpp\", mesh,
{{{{\"iterations\", int64_t{{5}}}}}})` runs a service as a host does (defaults filled in,
parameters checked, every edit checked and recorded, a check read-only) and gives the
result mesh with its content hash, the report, a check's value and the edits;
`test/taubin_test.cpp` is the example.

{LIMITS}
meshflow's `examples/plugin-template-cpp/README.md` describes the SDK.
"
    )
}
