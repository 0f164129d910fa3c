// Format 3's zstd frame of a chunk's body (chunk_body.h): compressed with
// its content size and checksum, checked before it is decompressed.
#include <new>
#include <stdexcept>
#include <utility>

#include <zstd.h>

#include "db/chunk_body.h"

namespace hapticlab::db::chunk {

namespace {

// zstd contexts, one per thread that encodes or decodes (the writer thread,
// analysis workers), kept for the thread's life: creating one costs more
// than compressing a chunk.
struct ZstdContexts {
  ZSTD_CCtx* c = nullptr;
  ZSTD_DCtx* d = nullptr;
  ~ZstdContexts() {
    ZSTD_freeCCtx(c);
    ZSTD_freeDCtx(d);
  }
};
thread_local ZstdContexts tls_zstd;

// zstd level 1: the fastest standard level; higher levels gained under 1 %
// in size on the demo study's chunks (BENCHMARKS.md, issue 20 goal 2).
constexpr int kZstdLevel = 1;

}  // namespace

// A plain body (preconditioned) as one zstd frame -- level 1, its content
// size and content checksum in it -- behind room for the 5-byte header.
std::vector<std::byte> compress_body(std::span<const std::byte> plain) {
  if (tls_zstd.c == nullptr) {
    if ((tls_zstd.c = ZSTD_createCCtx()) == nullptr) throw std::bad_alloc();
    for (const auto& [parameter, value] :
         {std::pair{ZSTD_c_compressionLevel, kZstdLevel}, std::pair{ZSTD_c_checksumFlag, 1},
          std::pair{ZSTD_c_contentSizeFlag, 1}}) {
      const std::size_t rc = ZSTD_CCtx_setParameter(tls_zstd.c, parameter, value);
      if (ZSTD_isError(rc))
        throw std::runtime_error(std::string("zstd refused a compression parameter: ") + ZSTD_getErrorName(rc));
    }
  }
  std::vector<std::byte> packed(kChunkHeaderBytes + ZSTD_compressBound(plain.size()));
  const std::size_t size = ZSTD_compress2(tls_zstd.c, packed.data() + kChunkHeaderBytes,
                                          packed.size() - kChunkHeaderBytes, plain.data(), plain.size());
  if (ZSTD_isError(size))
    throw std::runtime_error(std::string("zstd could not compress a sample chunk: ") + ZSTD_getErrorName(size));
  packed.resize(kChunkHeaderBytes + size);
  return packed;
}

// A chunk's zstd frame, checked before anything is allocated for it: one
// frame (RFC 8878 section 3.1.1: magic number, then the frame header
// descriptor) that states its content size, at most `most` bytes (what the
// row's count of updates can take), with the content checksum flag when
// `need_checksum`, and nothing after it. Returns the content size.
std::size_t check_frame(std::span<const std::byte> frame, std::size_t most, bool need_checksum) {
  constexpr std::array<std::uint8_t, 4> kMagic{0x28, 0xB5, 0x2F, 0xFD};  // 0xFD2FB528 little-endian
  bool magic = frame.size() > kMagic.size();
  for (std::size_t i = 0; magic && i < kMagic.size(); ++i) magic = std::to_integer<std::uint8_t>(frame[i]) == kMagic[i];
  if (!magic) throw structure("the zstd frame does not decompress (it does not start with a zstd frame's magic number)");
  const unsigned long long size = ZSTD_getFrameContentSize(frame.data(), frame.size());
  if (size == ZSTD_CONTENTSIZE_ERROR) throw structure("the zstd frame does not decompress (no valid frame header)");
  if (size == ZSTD_CONTENTSIZE_UNKNOWN) throw structure("the zstd frame does not state its content size");
  if (size > most)
    throw structure("the zstd frame's header states " + std::to_string(size) + " bytes, more than the " +
                    std::to_string(most) + " that the row's count of updates can take");
  // Frame_Header_Descriptor bit 2: Content_Checksum_flag.
  if (need_checksum && (std::to_integer<std::uint8_t>(frame[4]) & 0x04) == 0)
    throw structure("the zstd frame carries no content checksum (format 3 frames must)");
  const std::size_t compressed = ZSTD_findFrameCompressedSize(frame.data(), frame.size());
  if (ZSTD_isError(compressed))
    throw structure(std::string("the zstd frame does not decompress: ") + ZSTD_getErrorName(compressed));
  if (compressed != frame.size())
    throw structure(std::to_string(frame.size() - compressed) +
                    " bytes follow the zstd frame (a chunk holds exactly one frame)");
  return static_cast<std::size_t>(size);
}

// The checked frame decompressed into `out` (its content checksum, when it
// has one, verified by zstd).
void decompress(std::span<const std::byte> frame, std::size_t size, std::vector<std::byte>& out) {
  if (tls_zstd.d == nullptr && (tls_zstd.d = ZSTD_createDCtx()) == nullptr) throw std::bad_alloc();
  out.resize(size);
  const std::size_t got = ZSTD_decompressDCtx(tls_zstd.d, out.data(), out.size(), frame.data(), frame.size());
  if (ZSTD_isError(got) || got != size)
    throw structure(std::string("the zstd frame does not decompress: ") +
                    (ZSTD_isError(got) ? ZSTD_getErrorName(got) : "shorter than its header says"));
}

}  // namespace hapticlab::db::chunk
