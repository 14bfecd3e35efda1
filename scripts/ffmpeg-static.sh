#!/usr/bin/env bash
# A small static FFmpeg (libavcodec, libavformat, libswscale, libavutil:
# decoders and demuxers for the video a person records, nothing else) for
# the Python wheel, so that the wheel links no system library beyond glibc
# and qualifies as manylinux. The command line keeps using Debian's shared
# libav* (scripts/setup.sh).
#
#   scripts/ffmpeg-static.sh            -> $EYEREPLAY_CACHE/ffmpeg-static (FFMPEG_DIR for the build)
#
# The build itself goes to a cache shared by every checkout on the machine,
# ${XDG_CACHE_HOME:-~/.cache}/eyereplay/ffmpeg-static-<version>-<flags hash>
# (EYEREPLAY_SHARED_CACHE overrides the folder), and
# $EYEREPLAY_CACHE/ffmpeg-static links to it: it depends only on the pinned
# source and the configure flags below, and each fresh clone (CI's among
# them) would otherwise spend 3-4 minutes building the same bytes again.
#
# The source is Debian's own FFmpeg 5.1 (the same release as its libav*
# packages that the command line builds against), fetched with apt-get
# source from the machine's configured Debian mirror, with a private sources
# list and state folder in the cache (the system's apt configuration is not
# touched), and pinned by version and sha256. Building takes about 3 min on
# 2 cores, once; later runs find the finished tree and skip.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cache="${EYEREPLAY_CACHE:-$root/.cache}"
VERSION=5.1.9
DEB_VERSION=7:5.1.9-0+deb12u1
ORIG=ffmpeg_${VERSION}.orig.tar.xz
ORIG_SHA=d9b593bb2ba93d4b50f74177e0cdcd41747e708596367deed0c30348a71dd176
# What ./configure is given (below): part of the shared build's name, so
# changing a flag builds a new one instead of reusing the old.
CONFIGURE_FLAGS=(--enable-static --disable-shared --enable-pic
  --disable-programs --disable-doc --disable-network --disable-autodetect
  --disable-everything --disable-avdevice --disable-avfilter --disable-swresample
  --disable-postproc --enable-avcodec --enable-avformat --enable-swscale
  --enable-decoder=h264,hevc,vp8,vp9,mpeg4,h263,mjpeg,mpeg1video,mpeg2video,prores,dnxhd,vp3,theora,msmpeg4v2,msmpeg4v3,rawvideo,png
  --enable-demuxer=mov,matroska,avi,mpegts,mpegps,flv,h264,hevc,m4v,mjpeg,ivf,ogg,rawvideo,image2
  --enable-parser=h264,hevc,mpeg4video,mpegvideo,vp8,vp9,mjpeg,vp3,png
  --enable-protocol=file,pipe)
flags_hash="$(printf '%s\n' "$ORIG_SHA" "${CONFIGURE_FLAGS[@]}" | sha256sum | cut -c1-12)"
shared="${EYEREPLAY_SHARED_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/eyereplay}"
dest="$shared/ffmpeg-static-$VERSION-$flags_hash"
link="$cache/ffmpeg-static"
stamp="$dest/.built-$VERSION"
say() { echo "ffmpeg-static: $*"; }
# $link -> $dest (a folder left there by an older version of this script
# is replaced).
link_cache() {
  mkdir -p "$cache"
  if [[ "$(readlink "$link" 2>/dev/null)" != "$dest" ]]; then
    rm -rf "$link"
    ln -s "$dest" "$link"
  fi
}
if [[ -f "$stamp" ]]; then
  link_cache
  say "have FFmpeg $VERSION in $dest"
  exit 0
fi

# nasm: FFmpeg's x86 SIMD (decoding several times faster).
if ! command -v nasm >/dev/null; then
  say "apt-get install nasm"
  sudo_cmd=""
  [[ $(id -u) -ne 0 ]] && sudo_cmd="sudo"
  DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq --no-install-recommends nasm >/dev/null
fi

src="$shared/ffmpeg-src"
mkdir -p "$src"
if [[ ! -f "$src/$ORIG" || "$(sha256sum "$src/$ORIG" | cut -d' ' -f1)" != "$ORIG_SHA" ]]; then
  # deb-src twins of the deb entries the system already uses (same
  # mirrors, suites and keys).
  apt_dir="$shared/apt-src"
  rm -rf "$apt_dir/parts"
  mkdir -p "$apt_dir/parts" "$apt_dir/lists/partial"
  for f in /etc/apt/sources.list.d/*.sources; do
    [[ -f "$f" ]] && sed 's/^Types:.*/Types: deb-src/' "$f" > "$apt_dir/parts/$(basename "$f")"
  done
  for f in /etc/apt/sources.list /etc/apt/sources.list.d/*.list; do
    [[ -f "$f" ]] && { grep -E '^deb ' "$f" | sed 's/^deb /deb-src /' > "$apt_dir/parts/$(basename "$f").list" || true; }
  done
  if ! grep -qs "deb-src" "$apt_dir/parts/"*; then
    echo "ffmpeg-static: no Debian mirror configured in /etc/apt; cannot fetch FFmpeg's source" >&2
    exit 1
  fi
  opts=(-o "Dir::Etc::SourceList=$apt_dir/none.list" -o "Dir::Etc::SourceParts=$apt_dir/parts"
        -o "Dir::State::Lists=$apt_dir/lists" -o "APT::Sandbox::User=root")
  touch "$apt_dir/none.list"
  say "apt-get source ffmpeg=$DEB_VERSION (download only)"
  apt-get -qq "${opts[@]}" update
  (cd "$src" && apt-get -qq "${opts[@]}" source --download-only "ffmpeg=$DEB_VERSION" >/dev/null) || {
    echo "ffmpeg-static: Debian's mirror no longer has ffmpeg $DEB_VERSION; update VERSION, DEB_VERSION and ORIG_SHA in $0" >&2
    exit 1
  }
  got="$(sha256sum "$src/$ORIG" | cut -d' ' -f1)"
  if [[ "$got" != "$ORIG_SHA" ]]; then
    echo "ffmpeg-static: $src/$ORIG: sha256 $got, expected $ORIG_SHA" >&2
    exit 1
  fi
fi

build="$src/build-$VERSION-$flags_hash"
rm -rf "$build" "$dest"
mkdir -p "$build"
tar -xJf "$src/$ORIG" -C "$build" --strip-components=1
say "configure + make (static, decoders only)"
cd "$build"
./configure --prefix="$dest" "${CONFIGURE_FLAGS[@]}" >/dev/null
make -j"$(nproc)" >"$build/make.log" 2>&1 || { tail -20 "$build/make.log" >&2; exit 1; }
make install >>"$build/make.log" 2>&1
# The stamp last: a build killed half-way is redone, never half-used.
touch "$stamp"
link_cache
say "installed FFmpeg $VERSION (static) in $dest"
