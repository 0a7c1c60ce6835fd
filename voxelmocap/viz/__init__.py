"""Pictures for people: plots of errors, overlays on camera images."""
