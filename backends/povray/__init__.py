"""POV-Ray backend: compile a Scene to POV-Ray 3.7 SDL, run povray, read the image back."""
