"""QR codes: issuing, sizing, placement and verification."""
