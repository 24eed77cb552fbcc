//! Accessors: typed reads of buffer views (byte offset, stride and count checked against the
//! view and the buffer), sparse substitution, normalized integers dequantized as the glTF
//! spec says (`KHR_mesh_quantization`), attributes of a given width and index lists.

use ::gltf::accessor::{DataType, Dimensions};

use super::Msg;

/// Most components of an accessor not backed by a buffer (sparse accessor without a view).
const MAX_UNBACKED_COMPONENTS: usize = 1 << 28;

/// The bytes of a buffer view, checked against its buffer.
pub(super) fn view_bytes<'b>(view: &::gltf::buffer::View, buffers: &'b [Vec<u8>]) -> Msg<&'b [u8]> {
    let buffer = buffers
        .get(view.buffer().index())
        .ok_or_else(|| format!("bufferView {}: no such buffer", view.index()))?;
    view.offset()
        .checked_add(view.length())
        .and_then(|end| buffer.get(view.offset()..end))
        .ok_or_else(|| {
            format!(
                "bufferView {} (bytes {}..+{}) lies outside buffer {} ({} bytes)",
                view.index(),
                view.offset(),
                view.length(),
                view.buffer().index(),
                buffer.len()
            )
        })
}

/// One component, little-endian; `b` holds at least `ty.size()` bytes.
#[inline]
fn component(b: &[u8], ty: DataType) -> f64 {
    match ty {
        DataType::I8 => f64::from(b[0] as i8),
        DataType::U8 => f64::from(b[0]),
        DataType::I16 => f64::from(i16::from_le_bytes([b[0], b[1]])),
        DataType::U16 => f64::from(u16::from_le_bytes([b[0], b[1]])),
        DataType::U32 => f64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
        DataType::F32 => f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
    }
}

/// Reads all `count · dims` components of an accessor (dense part and sparse substitution),
/// converting each with `conv`. Every range is checked; nothing is allocated beyond what the
/// buffers back (or [`MAX_UNBACKED_COMPONENTS`]).
fn read_accessor<T: Copy>(
    acc: &::gltf::Accessor,
    buffers: &[Vec<u8>],
    conv: impl Fn(f64) -> T,
) -> Msg<Vec<T>> {
    let ty = acc.data_type();
    let dims = acc.dimensions().multiplicity();
    let csize = ty.size();
    let elem = dims * csize;
    let count = acc.count();
    let mut out;
    if let Some(view) = acc.view() {
        let data = view_bytes(&view, buffers)?;
        let stride = view.stride().unwrap_or(elem);
        if stride < elem {
            return Err(format!(
                "byteStride {stride} is smaller than the element size {elem}"
            ));
        }
        let data = if count == 0 {
            &[][..]
        } else {
            let end = stride
                .checked_mul(count - 1)
                .and_then(|n| n.checked_add(elem))
                .and_then(|n| n.checked_add(acc.offset()));
            end.and_then(|end| data.get(acc.offset()..end))
                .ok_or_else(|| {
                    format!(
                        "{count} elements of {elem} bytes (stride {stride}) from byte {} do not \
                         fit in bufferView {} ({} bytes)",
                        acc.offset(),
                        view.index(),
                        data.len()
                    )
                })?
        };
        out = Vec::with_capacity(count * dims);
        for i in 0..count {
            let e = &data[i * stride..i * stride + elem];
            for c in 0..dims {
                out.push(conv(component(&e[c * csize..], ty)));
            }
        }
    } else {
        let n = count.saturating_mul(dims);
        if n > MAX_UNBACKED_COMPONENTS {
            return Err(format!("{count} elements without a bufferView"));
        }
        out = vec![conv(0.0); n];
    }
    if let Some(sparse) = acc.sparse() {
        let n = sparse.count();
        let indices = sparse.indices();
        let ity = match indices.index_type() {
            ::gltf::accessor::sparse::IndexType::U8 => DataType::U8,
            ::gltf::accessor::sparse::IndexType::U16 => DataType::U16,
            ::gltf::accessor::sparse::IndexType::U32 => DataType::U32,
        };
        let idx_bytes = view_bytes(&indices.view(), buffers)?;
        let idx_bytes = n
            .checked_mul(ity.size())
            .and_then(|len| len.checked_add(indices.offset()))
            .and_then(|end| idx_bytes.get(indices.offset()..end))
            .ok_or_else(|| format!("sparse indices ({n}) outside their bufferView"))?;
        let values = sparse.values();
        let val_bytes = view_bytes(&values.view(), buffers)?;
        let val_bytes = n
            .checked_mul(elem)
            .and_then(|len| len.checked_add(values.offset()))
            .and_then(|end| val_bytes.get(values.offset()..end))
            .ok_or_else(|| format!("sparse values ({n}) outside their bufferView"))?;
        for k in 0..n {
            let target = component(&idx_bytes[k * ity.size()..], ity) as usize;
            if target >= count {
                return Err(format!(
                    "sparse index {target} out of range ({count} elements)"
                ));
            }
            let e = &val_bytes[k * elem..(k + 1) * elem];
            for c in 0..dims {
                out[target * dims + c] = conv(component(&e[c * csize..], ty));
            }
        }
    }
    Ok(out)
}

/// Component → float per the glTF rules for normalized integers.
#[inline]
fn dequantize(v: f64, ty: DataType, normalized: bool) -> f32 {
    if !normalized {
        return v as f32;
    }
    let r = match ty {
        DataType::I8 => (v / 127.0).max(-1.0),
        DataType::U8 => v / 255.0,
        DataType::I16 => (v / 32767.0).max(-1.0),
        DataType::U16 => v / 65535.0,
        DataType::U32 => v / 4_294_967_295.0,
        DataType::F32 => v,
    };
    r as f32
}

/// Reads a float attribute with `dims` components per element.
pub(super) fn read_attribute(
    acc: &::gltf::Accessor,
    buffers: &[Vec<u8>],
    dims: usize,
) -> Msg<Vec<f32>> {
    let found = acc.dimensions().multiplicity();
    if found != dims || matches!(acc.dimensions(), Dimensions::Mat2) {
        return Err(format!(
            "accessor {} has type {:?}, expected {dims} components",
            acc.index(),
            acc.dimensions()
        ));
    }
    let (ty, normalized) = (acc.data_type(), acc.normalized());
    read_accessor(acc, buffers, |v| dequantize(v, ty, normalized))
        .map_err(|e| format!("accessor {}: {e}", acc.index()))
}

/// Reads an index accessor (scalar unsigned integers).
pub(super) fn read_indices(acc: &::gltf::Accessor, buffers: &[Vec<u8>]) -> Msg<Vec<u32>> {
    if acc.dimensions() != Dimensions::Scalar
        || !matches!(
            acc.data_type(),
            DataType::U8 | DataType::U16 | DataType::U32
        )
    {
        return Err(format!(
            "index accessor {} is {:?} {:?}, expected SCALAR unsigned integers",
            acc.index(),
            acc.dimensions(),
            acc.data_type()
        ));
    }
    read_accessor(acc, buffers, |v| v as u32).map_err(|e| format!("accessor {}: {e}", acc.index()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dequantization_follows_the_spec() {
        assert_eq!(dequantize(-128.0, DataType::I8, true), -1.0);
        assert_eq!(dequantize(127.0, DataType::I8, true), 1.0);
        assert_eq!(dequantize(65535.0, DataType::U16, true), 1.0);
        assert_eq!(dequantize(7.0, DataType::U16, false), 7.0);
    }
}
