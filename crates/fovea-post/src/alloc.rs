//! Screen-sized buffers. An 8K frame's colour and depth take half a gigabyte, and touching
//! fresh memory one 4 KiB page at a time costs a page fault per page — on virtual machines
//! several microseconds each. [`zeroed`] asks the kernel for transparent huge pages (2 MiB)
//! where it allows them on request, before the first touch.

/// Bytes from which [`zeroed`] asks for huge pages.
const HUGE_PAGE_MIN_BYTES: usize = 8 << 20;

/// `n` zeros (`f32` planes, `[f32; N]` pixels), backed by huge pages where the OS offers them
/// (Linux `madvise(MADV_HUGEPAGE)`; elsewhere, and when refused, ordinary pages). The zeros
/// come from the allocator's zeroed memory, so nothing is written here: the pages are
/// faulted in — and zeroed by the kernel — where the caller first writes them, on its own
/// threads.
pub fn zeroed<T: Zero>(n: usize) -> Vec<T> {
    let mut v = vec![T::ZERO; n];
    advise_huge_pages(&mut v);
    v
}

/// Types whose zero `vec!` allocates as zeroed memory without writing it.
pub trait Zero: Clone {
    /// The zero value.
    const ZERO: Self;
}

impl Zero for f32 {
    const ZERO: Self = 0.0;
}

impl<const N: usize> Zero for [f32; N] {
    const ZERO: Self = [0.0; N];
}

#[cfg(target_os = "linux")]
fn advise_huge_pages<T>(v: &mut Vec<T>) {
    const HUGE: usize = 2 << 20;
    let bytes = v.capacity() * std::mem::size_of::<T>();
    if bytes < HUGE_PAGE_MIN_BYTES {
        return;
    }
    let start = v.as_mut_ptr() as usize;
    let aligned = start.next_multiple_of(HUGE);
    let len = (start + bytes).saturating_sub(aligned) / HUGE * HUGE;
    if len == 0 {
        return;
    }
    // SAFETY: `[aligned, aligned + len)` lies inside `v`'s live allocation (its capacity,
    // not yet written). MADV_HUGEPAGE is advice about how the kernel backs those pages; it
    // changes neither their contents nor their validity, and a refusal is harmless.
    unsafe {
        libc::madvise(aligned as *mut libc::c_void, len, libc::MADV_HUGEPAGE);
    }
}

#[cfg(not(target_os = "linux"))]
fn advise_huge_pages<T>(_v: &mut Vec<T>) {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zeroed_holds_n_zeros() {
        for n in [0usize, 1, 1000, 3 << 20] {
            let v = zeroed::<[f32; 3]>(n);
            assert_eq!(v.len(), n);
            assert!(v.iter().all(|&x| x == [0.0; 3]));
            assert!(zeroed::<f32>(n).iter().all(|&x| x == 0.0));
        }
    }
}
