//! The few functions of Intel Open Image Denoise's C API (OIDN 2.x, `oidn.h`) that the
//! denoiser needs, resolved from the shared library at run time: a device, the "RT"
//! filter, shared float3 images, one bool parameter, execute, and the error check.
//!
//! Loaded at run time (libloading) rather than linked: no OIDN is installed where Caustic is
//! built, and Blender ships the library (`bpy/lib/libOpenImageDenoise.so.2`), so the binary
//! runs without it and finds Blender's copy only when `--denoise` asks for it.

use libloading::Library;
use std::ffi::{CStr, CString, c_char, c_void};
use std::path::Path;

/// OIDN_DEVICE_TYPE_CPU: the renderer's images live in host memory.
const DEVICE_CPU: i32 = 1;
/// OIDN_FORMAT_FLOAT3.
const FORMAT_FLOAT3: i32 = 3;
/// OIDN_ERROR_NONE.
const ERROR_NONE: i32 = 0;

type NewDevice = unsafe extern "C" fn(i32) -> *mut c_void;
type Handle = unsafe extern "C" fn(*mut c_void);
type GetError = unsafe extern "C" fn(*mut c_void, *mut *const c_char) -> i32;
type NewFilter = unsafe extern "C" fn(*mut c_void, *const c_char) -> *mut c_void;
type SetImage = unsafe extern "C" fn(*mut c_void, *const c_char, *mut c_void, i32, usize, usize, usize, usize, usize);
type SetBool = unsafe extern "C" fn(*mut c_void, *const c_char, bool);

/// The loaded library and its entry points.
pub struct Oidn {
    new_device: NewDevice,
    commit_device: Handle,
    release_device: Handle,
    get_device_error: GetError,
    new_filter: NewFilter,
    set_image: SetImage,
    set_bool: SetBool,
    commit_filter: Handle,
    execute_filter: Handle,
    release_filter: Handle,
    // Keeps the code behind the function pointers mapped; dropped last.
    _lib: Library,
}

/// One denoising pass of the "RT" filter: its images (RGB, row-major, width × height).
pub struct FilterImages<'a> {
    /// The image to denoise ("color"): the beauty, or an albedo or normal being prefiltered.
    pub color: &'a [[f32; 3]],
    /// Auxiliary albedo, if any.
    pub albedo: Option<&'a [[f32; 3]]>,
    /// Auxiliary normal, if any.
    pub normal: Option<&'a [[f32; 3]]>,
    /// High dynamic range colour (the beauty image; false for albedo and normal).
    pub hdr: bool,
    /// The auxiliary images are noise-free (prefiltered).
    pub clean_aux: bool,
}

impl Oidn {
    /// Loads the library at `path` (a file, or a name the system loader searches for) and
    /// resolves every entry point; the error says which was missing.
    pub fn load(path: &Path) -> Result<Oidn, String> {
        // SAFETY: loading runs the library's initialisers; OIDN's only set up its device
        // registry. The symbols are read with the signatures of oidn.h 2.x.
        unsafe {
            let lib = Library::new(path).map_err(|e| format!("cannot load '{}': {e}", path.display()))?;
            macro_rules! sym {
                ($name:literal) => {
                    *lib.get(concat!($name, "\0").as_bytes())
                        .map_err(|e| format!("'{}' is not OIDN 2 (no {}): {e}", path.display(), $name))?
                };
            }
            Ok(Oidn {
                new_device: sym!("oidnNewDevice"),
                commit_device: sym!("oidnCommitDevice"),
                release_device: sym!("oidnReleaseDevice"),
                get_device_error: sym!("oidnGetDeviceError"),
                new_filter: sym!("oidnNewFilter"),
                set_image: sym!("oidnSetSharedFilterImage"),
                set_bool: sym!("oidnSetFilterBool"),
                commit_filter: sym!("oidnCommitFilter"),
                execute_filter: sym!("oidnExecuteFilter"),
                release_filter: sym!("oidnReleaseFilter"),
                _lib: lib,
            })
        }
    }

    /// A committed CPU device (checked: a CPU without the instructions OIDN needs fails here).
    pub fn device(&self) -> Result<Device<'_>, String> {
        // SAFETY: the entry points have oidn.h's signatures; the handle is released on drop.
        let raw = unsafe { (self.new_device)(DEVICE_CPU) };
        if raw.is_null() {
            return Err("OIDN could not create a CPU device".into());
        }
        let device = Device { oidn: self, raw };
        // SAFETY: raw is a live device.
        unsafe { (self.commit_device)(raw) };
        device.check("creating the CPU device")?;
        Ok(device)
    }
}

/// An OIDN device, released on drop.
pub struct Device<'a> {
    oidn: &'a Oidn,
    raw: *mut c_void,
}

impl Device<'_> {
    /// The device's pending error, if any, as a message naming `what` was being done.
    fn check(&self, what: &str) -> Result<(), String> {
        let mut msg: *const c_char = std::ptr::null();
        // SAFETY: raw is a live device; OIDN owns the message string until the next call.
        let code = unsafe { (self.oidn.get_device_error)(self.raw, &mut msg) };
        if code == ERROR_NONE {
            return Ok(());
        }
        let text = if msg.is_null() {
            String::new()
        } else {
            // SAFETY: a non-null message is a NUL-terminated string owned by OIDN.
            unsafe { CStr::from_ptr(msg) }.to_string_lossy().into_owned()
        };
        Err(format!("OIDN failed {what} (error {code}): {text}"))
    }

    /// Runs the "RT" filter over `images` of `width` × `height`, writing into `output`.
    pub fn run(
        &self,
        width: usize,
        height: usize,
        images: FilterImages,
        output: &mut [[f32; 3]],
    ) -> Result<(), String> {
        let n = width * height;
        let sizes_ok = images.color.len() == n
            && output.len() == n
            && images.albedo.is_none_or(|a| a.len() == n)
            && images.normal.is_none_or(|v| v.len() == n);
        if !sizes_ok {
            return Err(format!("OIDN images do not all hold {width}x{height} pixels"));
        }
        let name = |s: &str| CString::new(s).expect("no NUL in a parameter name");
        // SAFETY: the filter is created on a live device and released below; every image
        // pointer is a live slice of n float3 pixels (checked above) that outlives the
        // execution, which is synchronous; OIDN only reads the inputs (the shared-image API
        // takes a mutable pointer for all of them).
        unsafe {
            let filter = (self.oidn.new_filter)(self.raw, name("RT").as_ptr());
            if filter.is_null() {
                self.check("creating the RT filter")?;
                return Err("OIDN has no RT filter".into());
            }
            let stride = std::mem::size_of::<[f32; 3]>();
            let set = |key: &str, ptr: *mut c_void| {
                (self.oidn.set_image)(filter, name(key).as_ptr(), ptr, FORMAT_FLOAT3, width, height, 0, stride, 0)
            };
            set("color", images.color.as_ptr() as *mut c_void);
            if let Some(a) = images.albedo {
                set("albedo", a.as_ptr() as *mut c_void);
            }
            if let Some(v) = images.normal {
                set("normal", v.as_ptr() as *mut c_void);
            }
            set("output", output.as_mut_ptr() as *mut c_void);
            (self.oidn.set_bool)(filter, name("hdr").as_ptr(), images.hdr);
            (self.oidn.set_bool)(filter, name("cleanAux").as_ptr(), images.clean_aux);
            (self.oidn.commit_filter)(filter);
            let committed = self.check("setting up the RT filter");
            if committed.is_ok() {
                (self.oidn.execute_filter)(filter);
            }
            (self.oidn.release_filter)(filter);
            committed?;
            self.check("denoising")
        }
    }
}

impl Drop for Device<'_> {
    fn drop(&mut self) {
        // SAFETY: raw is a live device, released once.
        unsafe { (self.oidn.release_device)(self.raw) };
    }
}
