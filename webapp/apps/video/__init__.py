"""The video app: an instructor's MP4 or WebM played across the wall, each display its
part of the frame, every tile in step on the wall clock (docs/video.md)."""
