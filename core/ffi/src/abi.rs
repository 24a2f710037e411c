// Included by build.rs as well (`include!`), which names the shared library after it; so this
// file holds nothing but the constant.

/// The version of the C ABI: the layout of every struct and the signature of every call in
/// `sinew.h`. It changes when a released struct or call changes incompatibly (a call or a status
/// code added keeps it); `libsinew.so`'s SONAME is `libsinew.so.SINEW_ABI_VERSION`, and
/// `sinew_abi_version()` returns the library's, so a program can check it was built with the
/// header of the library it loads.
pub const SINEW_ABI_VERSION: u32 = 1;
