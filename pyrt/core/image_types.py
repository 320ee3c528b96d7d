"""Image file types from their first bytes (magic numbers), for :func:`pyrt.core.image_io.read_image` and the
glTF loader's embedded images: the type is taken from the data, never from a file name or MIME type."""
from __future__ import annotations

#: Radiance .hdr headers
HDR_MAGIC = (b"#?RADIANCE", b"#?RGBE")
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
EXR_MAGIC = b"\x76\x2f\x31\x01"
OTHER_MAGIC = ((b"\xff\xd8\xff", "JPEG"), (b"II*\0", "TIFF"), (b"MM\0*", "TIFF"), (b"BM", "BMP"), (b"GIF8", "GIF"))
AVIF_BRANDS = (b"avif", b"avis")


def image_kind(head):
    """The type of an 8/16-bit image file whose first bytes are ``head`` (16 bytes suffice): ``"PNG"``, ``"JPEG"``,
    ``"TIFF"``, ``"BMP"``, ``"GIF"``, ``"WebP"`` (a RIFF container of type ``WEBP``) or ``"AVIF"`` (an ISO-BMFF
    ``ftyp`` box of brand ``avif`` / ``avis``), or None (EXR and .hdr are not asked here)."""
    if head[:8] == PNG_MAGIC:
        return "PNG"
    kind = next((k for m, k in OTHER_MAGIC if head[:len(m)] == m), None)
    if kind is None and head[:4] == b"RIFF" and head[8:12] == b"WEBP":
        kind = "WebP"
    elif kind is None and head[4:8] == b"ftyp" and head[8:12] in AVIF_BRANDS:
        kind = "AVIF"
    return kind
