//! The WebAssembly module's exports: plain `extern "C"` functions over numbers, which
//! `core/wasm/js/sinew.mjs` wraps into the JavaScript API.
//!
//! # Protocol
//! Data crosses through one exchange buffer, the *I/O area*, a `Vec<u8>` owned here. JavaScript
//! asks for room with [`sinew_io_reserve`], copies its bytes (a model's file, or `f32` inputs
//! as little-endian values) to the address returned, then calls an operation. An operation reads
//! its inputs from the I/O area, replaces the area with its result and returns the result's
//! length in bytes (read it at [`sinew_io_ptr`]), or `-1` when it failed: [`sinew_error`] then
//! puts the message in the I/O area (when the core refused an input, [`sinew_error_argument`]
//! and [`sinew_error_index`], called first, say which). No Rust reference to the area is alive between calls, so
//! JavaScript's writes never alias a borrow; memory can grow during any call, so JavaScript
//! takes a fresh view of it after each.
//!
//! Models, replays, performances, motion generators and drivers live in a table here;
//! JavaScript holds their handles (positive `i32`) and hands them back with [`sinew_free`].
//! Pointers are 32-bit on `wasm32`, the only target these functions are meant for (on the host
//! they are compiled and linted, not called).
//!
//! Every export carries `#[unsafe(no_mangle)]` (exported under its own name), the one kind of
//! unsafe code in this crate; no other symbol in the module has a `sinew_` name.

use std::cell::{Cell, RefCell};

use crate::driver::Driver;
use crate::error::{Error, Refused};
use crate::model::Model;
use crate::motion::Motion;
use crate::performance::Performance;
use crate::replay::{FrameInputs, Replay};

mod driver;

#[derive(Debug)]
enum Object {
    Model(Model),
    Replay(Replay),
    Performance(Performance),
    Motion(Motion),
    Driver(Driver),
}

impl Object {
    /// "a model", "a replay", … ([`Kind::WHAT`]), for messages about a handle of the wrong kind.
    const fn what(&self) -> &'static str {
        match self {
            Self::Model(_) => Model::WHAT,
            Self::Replay(_) => Replay::WHAT,
            Self::Performance(_) => Performance::WHAT,
            Self::Motion(_) => Motion::WHAT,
            Self::Driver(_) => Driver::WHAT,
        }
    }
}

thread_local! {
    /// The I/O area (see the module documentation).
    static IO: RefCell<Vec<u8>> = const { RefCell::new(Vec::new()) };
    /// The message of the last failed operation.
    static ERROR: RefCell<String> = const { RefCell::new(String::new()) };
    /// The input the core refused in the last failed operation, if that was why it failed.
    static REFUSED: Cell<Option<Refused>> = const { Cell::new(None) };
    /// The objects behind the handles; handle `h` is slot `h − 1`.
    static OBJECTS: RefCell<Vec<Option<Object>>> = const { RefCell::new(Vec::new()) };
}

/// What an operation returns: its result's bytes (placed in the I/O area) or an error.
type Outcome = Result<Vec<u8>, Error>;

/// Places `outcome` in the I/O area (or the error message aside) and returns the export's
/// status: the result's length in bytes, or -1.
fn finish(outcome: Outcome) -> i32 {
    let outcome = outcome.and_then(|bytes| {
        i32::try_from(bytes.len())
            .map(|len| (bytes, len))
            .map_err(|_| Error::new("result is larger than 2 GiB"))
    });
    match outcome {
        Ok((bytes, len)) => {
            IO.with_borrow_mut(|io| *io = bytes);
            len
        }
        Err(e) => {
            fail(e);
            -1
        }
    }
}

/// The I/O area's contents as little-endian `f32` values (a trailing partial value is ignored;
/// JavaScript always writes whole values).
fn io_f32s() -> Vec<f32> {
    IO.with_borrow(|io| {
        let (values, _) = io.as_chunks::<4>();
        values.iter().map(|c| f32::from_le_bytes(*c)).collect()
    })
}

fn io_bytes() -> Vec<u8> {
    IO.with_borrow_mut(std::mem::take)
}

fn f32_bytes(values: &[f32]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

fn u32_bytes(values: &[u32]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

/// Splits `values` at `first` values: the two inputs an operation read from the I/O area.
fn split_at(values: &[f32], first: u32) -> Result<(&[f32], &[f32]), Error> {
    values
        .split_at_checked(first as usize)
        .ok_or_else(|| Error::new("inputs are shorter than their stated lengths"))
}

fn slot(handle: i32) -> Option<usize> {
    usize::try_from(handle).ok()?.checked_sub(1)
}

fn stale(handle: i32) -> Error {
    Error::new(format!(
        "handle {handle} is not a live model, replay, performance, motion generator or driver"
    ))
}

fn not_a(handle: i32, object: &Object, wanted: &str) -> Error {
    Error::new(format!(
        "handle {handle} is {}, not {wanted}",
        object.what()
    ))
}

/// A kind of object an export asks a handle for.
trait Kind: Sized {
    /// "a replay", … for messages about a handle of another kind.
    const WHAT: &'static str;
    /// The object as this kind, if it is one.
    fn of(object: &Object) -> Option<&Self>;
}

macro_rules! kinds {
    ($($kind:ident: $what:literal),*) => {$(
        impl Kind for $kind {
            const WHAT: &'static str = $what;
            fn of(object: &Object) -> Option<&Self> {
                match object {
                    Object::$kind(x) => Some(x),
                    _ => None,
                }
            }
        }
    )*};
}

kinds!(
    Model: "a model",
    Replay: "a replay",
    Performance: "a performance",
    Motion: "a motion generator",
    Driver: "a landmark driver"
);

/// The object of kind `K` behind `handle`.
fn get<K: Kind>(objects: &[Option<Object>], handle: i32) -> Result<&K, Error> {
    match slot(handle)
        .and_then(|i| objects.get(i))
        .and_then(Option::as_ref)
    {
        Some(object) => K::of(object).ok_or_else(|| not_a(handle, object, K::WHAT)),
        None => Err(stale(handle)),
    }
}

/// Runs `f` on the object of kind `K` behind `handle`.
fn with<K: Kind, T>(handle: i32, f: impl FnOnce(&K) -> Result<T, Error>) -> Result<T, Error> {
    OBJECTS.with_borrow(|objects| f(get(objects, handle)?))
}

/// Runs `f` on the object of kind `K` behind `handle` and the model behind `model`.
fn with_on_model<K: Kind, T>(
    handle: i32,
    model: i32,
    f: impl FnOnce(&K, &Model) -> Result<T, Error>,
) -> Result<T, Error> {
    OBJECTS.with_borrow(|objects| f(get(objects, handle)?, get(objects, model)?))
}

/// Runs `f` on the model behind `handle`.
fn with_model<T>(handle: i32, f: impl FnOnce(&mut Model) -> Result<T, Error>) -> Result<T, Error> {
    OBJECTS.with_borrow_mut(|objects| {
        match slot(handle)
            .and_then(|i| objects.get_mut(i))
            .and_then(Option::as_mut)
        {
            Some(Object::Model(m)) => f(m),
            Some(other) => Err(not_a(handle, other, "a model")),
            None => Err(stale(handle)),
        }
    })
}

/// Stores `object` and returns its handle.
fn insert(object: Object) -> Result<i32, Error> {
    OBJECTS.with_borrow_mut(|objects| {
        let i = match objects.iter().position(Option::is_none) {
            Some(i) => i,
            None => {
                objects.push(None);
                objects.len() - 1
            }
        };
        let handle = i32::try_from(i + 1).map_err(|_| Error::new("too many live objects"))?;
        if let Some(s) = objects.get_mut(i) {
            *s = Some(object);
        }
        Ok(handle)
    })
}

/// A handle, or -1 with the error kept for [`sinew_error`].
fn handle_or_error(result: Result<i32, Error>) -> i32 {
    match result {
        Ok(h) => h,
        Err(e) => {
            fail(e);
            -1
        }
    }
}

/// Makes the I/O area `len` bytes long (zeroed) and returns its address, where JavaScript then
/// writes an operation's inputs.
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_io_reserve(len: u32) -> u32 {
    IO.with_borrow_mut(|io| {
        io.clear();
        io.resize(len as usize, 0);
        io.as_mut_ptr() as usize as u32
    })
}

/// The address of the I/O area, where the last operation's result starts.
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_io_ptr() -> u32 {
    IO.with_borrow_mut(|io| io.as_mut_ptr() as usize as u32)
}

/// Keeps a failure for [`sinew_error`] and, when the core refused an input,
/// [`sinew_error_argument`] and [`sinew_error_index`].
fn fail(e: Error) {
    REFUSED.set(e.refused());
    ERROR.with_borrow_mut(|m| *m = e.message().to_owned());
}

/// When the last failure was a refused input: puts the argument's name (UTF-8) in the I/O area
/// and returns its length; otherwise -1. Call it before [`sinew_error`], which forgets it.
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_error_argument() -> i32 {
    match REFUSED.get() {
        Some(r) => finish(Ok(r.argument.as_bytes().to_vec())),
        None => -1,
    }
}

/// When the last failure was a refused input, the value's index in its argument; otherwise -1.
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_error_index() -> i32 {
    REFUSED
        .get()
        .map_or(-1, |r| i32::try_from(r.index).unwrap_or(i32::MAX))
}

/// Puts the last failure's message (UTF-8) in the I/O area; returns its length in bytes.
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_error() -> i32 {
    REFUSED.set(None);
    finish(Ok(ERROR.with_borrow_mut(std::mem::take).into_bytes()))
}

/// Loads the model whose bytes are in the I/O area ([`Model::load`]); returns its handle, or -1.
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_model_load() -> i32 {
    handle_or_error(Model::load(io_bytes()).and_then(|m| insert(Object::Model(m))))
}

/// Loads the replay whose bytes are in the I/O area ([`Replay::load`]); returns its handle, or
/// -1.
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_replay_load() -> i32 {
    handle_or_error(Replay::load(io_bytes()).and_then(|r| insert(Object::Replay(r))))
}

/// Frees the object behind `handle` (nothing for a handle not in use).
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_free(handle: i32) {
    OBJECTS.with_borrow_mut(|objects| {
        if let Some(s) = slot(handle).and_then(|i| objects.get_mut(i)) {
            *s = None;
        }
    });
}

/// Describes the object behind `handle` as `key=value` lines: for a model `kind`, `vertices`,
/// `shapes`, `inputs`, `triangles` and `hash` (16 hex digits); for a replay `kind`, `mode`,
/// `frames`, `model` (the model's hash) and `neutral` (1 if it carries one); for a performance
/// `kind=performance`, `form` (`global` or `local`), `frames`, `shapes`, `model` and `hashes` (1
/// if it carries its frames' hashes); for a motion generator `kind=motion`, `labels`, `frames`,
/// `landmarks` and `noise`; for a landmark driver `kind=driver`, `space` (`2d` or `3d`),
/// `inputs`, `pose`, `shapes`, `model` and `state` (the filter state's length).
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_info(handle: i32) -> i32 {
    let text = OBJECTS.with_borrow(|objects| {
        match slot(handle)
            .and_then(|i| objects.get(i))
            .and_then(Option::as_ref)
        {
            Some(Object::Model(m)) => Ok(format!(
                "kind={}\nvertices={}\nshapes={}\ninputs={}\ntriangles={}\nhash={:016x}\n",
                m.kind().name(),
                m.vertex_count(),
                m.shape_count(),
                m.input_len(),
                m.triangle_count(),
                m.content_hash()
            )),
            Some(Object::Replay(r)) => Ok(format!(
                "kind={}\nmode={}\nframes={}\nmodel={:016x}\nneutral={}\n",
                r.kind().name(),
                r.mode(),
                r.frames(),
                r.model_hash(),
                u8::from(r.has_neutral())
            )),
            Some(Object::Performance(p)) => Ok(format!(
                "kind=performance\nform={}\nframes={}\nshapes={}\nmodel={:016x}\nhashes={}\n",
                if p.is_local() { "local" } else { "global" },
                p.frames(),
                p.shape_count(),
                p.model_hash(),
                u8::from(p.has_hashes())
            )),
            Some(Object::Motion(m)) => Ok(format!(
                "kind=motion\nlabels={}\nframes={}\nlandmarks={}\nnoise={}\n",
                m.label_count(),
                m.frame_count(),
                m.landmark_count(),
                m.noise_len()
            )),
            Some(Object::Driver(d)) => Ok(format!(
                "kind=driver\nspace={}\ninputs={}\npose={}\nshapes={}\nmodel={:016x}\nstate={}\nlive={}\n",
                d.space(),
                d.input_len(),
                d.pose_len(),
                d.shape_count(),
                d.model_hash(),
                d.filter_state_len(),
                d.live_state_len()
            )),
            None => Err(stale(handle)),
        }
    });
    finish(text.map(String::into_bytes))
}

/// Puts the model's metadata text in the I/O area.
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_metadata(handle: i32) -> i32 {
    finish(with_model(handle, |m| Ok(m.metadata().as_bytes().to_vec())))
}

/// `which` of [`sinew_array`]: a model's triangle indices (`u32`).
pub const ARRAY_TRIANGLES: u32 = 0;
/// `which` of [`sinew_array`]: an S2D decoder's landmark vertices (`u32`).
pub const ARRAY_LANDMARKS: u32 = 1;
/// `which` of [`sinew_array`]: a model's neutral mesh (`f32`).
pub const ARRAY_NEUTRAL: u32 = 2;
/// `which` of [`sinew_array`]: an S2D replay's neutral (`f32`).
pub const ARRAY_REPLAY_NEUTRAL: u32 = 3;

/// `which` of [`sinew_array`]: an AIM actor's soft-tissue thickness per vertex (`f32`).
pub const ARRAY_THICKNESS: u32 = 4;

/// Puts one of the object's arrays (`ARRAY_*`) in the I/O area.
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_array(handle: i32, which: u32) -> i32 {
    finish(match which {
        ARRAY_TRIANGLES => with_model(handle, |m| Ok(u32_bytes(&m.triangles()))),
        ARRAY_LANDMARKS => with_model(handle, |m| Ok(u32_bytes(&m.landmark_vertices()))),
        ARRAY_NEUTRAL => with_model(handle, |m| Ok(f32_bytes(&m.neutral()))),
        ARRAY_THICKNESS => with_model(handle, |m| Ok(f32_bytes(&m.thickness()?))),
        ARRAY_REPLAY_NEUTRAL => with(handle, |r: &Replay| {
            r.neutral()
                .map(|n| f32_bytes(&n))
                .ok_or_else(|| Error::new("this replay carries no neutral"))
        }),
        _ => Err(Error::new(format!("unknown array {which}"))),
    })
}

/// Poses an AIM actor ([`Model::pose`]); the I/O area holds head (`head_len` values), jaw
/// (`jaw_len`) and coefficients (the rest). Result: the positions (`f32`).
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_pose(handle: i32, head_len: u32, jaw_len: u32) -> i32 {
    let values = io_f32s();
    finish(with_model(handle, |m| {
        let (head, rest) = split_at(&values, head_len)?;
        let (jaw, coefficients) = split_at(rest, jaw_len)?;
        Ok(f32_bytes(&m.pose(head, jaw, coefficients)?))
    }))
}

/// The jaw of the coefficients in the I/O area ([`Model::jaw_from_weights`]). Result: 9 `f32`.
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_jaw_from_weights(handle: i32) -> i32 {
    let values = io_f32s();
    finish(with_model(handle, |m| {
        Ok(f32_bytes(&m.jaw_from_weights(&values)?))
    }))
}

/// Vertex normals ([`Model::normals`]) of the positions in the I/O area. Result: `f32`.
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_normals(handle: i32) -> i32 {
    let values = io_f32s();
    finish(with_model(handle, |m| Ok(f32_bytes(&m.normals(&values)?))))
}

/// An S2D decoder's input ([`Model::landmark_input`]); the I/O area holds the neutral
/// landmarks (`neutral_len` values), then the expressive ones. Result: `f32`.
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_landmark_input(handle: i32, neutral_len: u32) -> i32 {
    let values = io_f32s();
    finish(with_model(handle, |m| {
        let (neutral, landmarks) = split_at(&values, neutral_len)?;
        Ok(f32_bytes(&m.landmark_input(neutral, landmarks)?))
    }))
}

/// Decodes an S2D input ([`Model::decode`]); the I/O area holds the input (`input_len` values),
/// then the neutral to decode onto, or nothing for the decoder's template. Result: `f32`.
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_decode(handle: i32, input_len: u32) -> i32 {
    let values = io_f32s();
    finish(with_model(handle, |m| {
        let (input, neutral) = split_at(&values, input_len)?;
        let neutral = (!neutral.is_empty()).then_some(neutral);
        Ok(f32_bytes(&m.decode(input, neutral)?))
    }))
}

/// The frame hash ([`crate::frame_hash`]) of the `f32` values in the I/O area. Result: 16 hex
/// digits.
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_frame_hash() -> i32 {
    let values = io_f32s();
    finish(Ok(
        format!("{:016x}", crate::frame_hash(&[&values])).into_bytes()
    ))
}

/// Frame `frame`'s inputs of a replay ([`Replay::frame`]). Result (`f32`): head, jaw and
/// coefficients for AIM, the decoder input for S2D.
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_replay_frame(handle: i32, frame: u32) -> i32 {
    finish(with(handle, |r: &Replay| {
        Ok(match r.frame(frame as usize)? {
            FrameInputs::Aim {
                head,
                jaw,
                coefficients,
            } => f32_bytes(&[&head[..], &jaw[..], &coefficients].concat()),
            FrameInputs::S2d(input) => f32_bytes(&input),
        })
    }))
}

/// The hash a replay recorded for frame `frame` ([`Replay::expected`]). Result: 16 hex digits.
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_replay_expected(handle: i32, frame: u32) -> i32 {
    finish(with(handle, |r: &Replay| {
        Ok(format!("{:016x}", r.expected(frame as usize)?).into_bytes())
    }))
}

/// Checks that a replay was recorded with a model ([`Replay::check`]). Result: empty.
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_replay_check(replay: i32, model: i32) -> i32 {
    finish(with_on_model(replay, model, |r: &Replay, m| {
        r.check(m).map(|()| Vec::new())
    }))
}

/// Loads the fitted performance whose bytes are in the I/O area ([`Performance::load`]); returns
/// its handle, or -1.
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_performance_load() -> i32 {
    handle_or_error(Performance::load(io_bytes()).and_then(|p| insert(Object::Performance(p))))
}

/// Checks that a performance was fitted to a model ([`Performance::check`]). Result: empty.
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_performance_check(perf: i32, model: i32) -> i32 {
    finish(with_on_model(perf, model, |p: &Performance, m| {
        p.check(m).map(|()| Vec::new())
    }))
}

/// Frame `frame` of a performance ([`Performance::frame`]). Result (`f32`): head, jaw, then the
/// coefficients of a global fit (nothing more for a local one).
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_performance_frame(perf: i32, frame: u32) -> i32 {
    finish(with(perf, |p: &Performance| {
        let f = p.frame(frame as usize)?;
        let coefficients = f.coefficients.unwrap_or_default();
        Ok(f32_bytes(
            &[&f.head[..], &f.jaw[..], &coefficients].concat(),
        ))
    }))
}

/// Poses `model` for frame `frame` of a performance ([`Performance::pose`]). Result: the
/// positions (`f32`).
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_performance_pose(perf: i32, model: i32, frame: u32) -> i32 {
    finish(with_on_model(perf, model, |p: &Performance, m| {
        Ok(f32_bytes(&p.pose(m, frame as usize)?))
    }))
}

/// Frame `frame`'s hash computed in the module ([`Performance::frame_hash`]). Result: 16 hex
/// digits.
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_performance_hash(perf: i32, model: i32, frame: u32) -> i32 {
    finish(with_on_model(perf, model, |p: &Performance, m| {
        let hash = p.frame_hash(m, frame as usize)?;
        Ok(format!("{hash:016x}").into_bytes())
    }))
}

/// The hash baked for frame `frame` ([`Performance::expected`]). Result: 16 hex digits, or
/// empty when the file carries no hashes.
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_performance_expected(perf: i32, frame: u32) -> i32 {
    finish(with(perf, |p: &Performance| {
        Ok(p.expected(frame as usize)?
            .map(|h| format!("{h:016x}").into_bytes())
            .unwrap_or_default())
    }))
}

/// The names, one per line, of a model's corrective shapes ([`Model::shape_names`]) or of a
/// motion generator's labels ([`Motion::label_names`]). Result: UTF-8 text.
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_names(handle: i32) -> i32 {
    let names = OBJECTS.with_borrow(|objects| {
        match slot(handle)
            .and_then(|i| objects.get(i))
            .and_then(Option::as_ref)
        {
            Some(Object::Model(m)) => Ok(m.shape_names()),
            Some(Object::Motion(m)) => Ok(m.label_names()),
            Some(other) => Err(not_a(handle, other, "a model or a motion generator")),
            None => Err(stale(handle)),
        }
    });
    finish(names.map(|n| n.join("\n").into_bytes()))
}

fn i32_bytes(values: &[i32]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

/// Poses an AIM actor in Q16.16 ([`Model::pose_q16`]); the I/O area as [`sinew_pose`]'s. Result:
/// the positions' raw Q16.16 values (`i32`).
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_pose_q16(handle: i32, head_len: u32, jaw_len: u32) -> i32 {
    let values = io_f32s();
    finish(with_model(handle, |m| {
        let (head, rest) = split_at(&values, head_len)?;
        let (jaw, coefficients) = split_at(rest, jaw_len)?;
        Ok(i32_bytes(&m.pose_q16(head, jaw, coefficients)?))
    }))
}

/// Poses an AIM actor in the fast mode ([`Model::pose_fast`]); the I/O area as [`sinew_pose`]'s.
/// Result (`f32`): the positions, then the normals.
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_pose_fast(handle: i32, head_len: u32, jaw_len: u32) -> i32 {
    let values = io_f32s();
    finish(with_model(handle, |m| {
        let (head, rest) = split_at(&values, head_len)?;
        let (jaw, coefficients) = split_at(rest, jaw_len)?;
        let (positions, normals) = m.pose_fast(head, jaw, coefficients)?;
        Ok(f32_bytes(&[positions, normals].concat()))
    }))
}

/// The Q16 frame hash ([`crate::frame_hash_q16`]) of the `i32` values in the I/O area. Result:
/// 16 hex digits.
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_frame_hash_q16() -> i32 {
    let values: Vec<i32> = IO.with_borrow(|io| {
        let (values, _) = io.as_chunks::<4>();
        values.iter().map(|c| i32::from_le_bytes(*c)).collect()
    });
    finish(Ok(
        format!("{:016x}", crate::frame_hash_q16(&values)).into_bytes()
    ))
}

/// Loads the motion generator whose bytes are in the I/O area ([`Motion::load`]); returns its
/// handle, or -1.
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_motion_load() -> i32 {
    handle_or_error(Motion::load(io_bytes()).and_then(|m| insert(Object::Motion(m))))
}

/// The landmark curve of a label and a seed ([`Motion::curve`]) on the decoder `model`; the I/O
/// area holds the neutral face to generate on, or nothing for the decoder's template. The seed
/// is `seed_high · 2³² + seed_low`. Result: the curve (`f32`).
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_motion_curve(
    motion: i32,
    model: i32,
    label: u32,
    seed_low: u32,
    seed_high: u32,
    intensity: f32,
) -> i32 {
    let neutral = io_f32s();
    let seed = (u64::from(seed_high) << 32) | u64::from(seed_low);
    finish(with_on_model(motion, model, |g: &Motion, m| {
        let neutral = (!neutral.is_empty()).then_some(&neutral[..]);
        Ok(f32_bytes(&g.curve(
            m,
            label as usize,
            seed,
            intensity,
            neutral,
        )?))
    }))
}

/// Frame `t` of a curve decoded on the decoder `model` ([`Motion::frame`]); the I/O area holds
/// the curve (`curve_len` values), then the neutral face, or nothing for the template. Result:
/// the vertices (`f32`).
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_motion_frame(motion: i32, model: i32, t: u32, curve_len: u32) -> i32 {
    let values = io_f32s();
    finish(with_on_model(motion, model, |g: &Motion, m| {
        let (curve, neutral) = split_at(&values, curve_len)?;
        let neutral = (!neutral.is_empty()).then_some(neutral);
        Ok(f32_bytes(&g.frame(m, curve, t as usize, neutral)?))
    }))
}
