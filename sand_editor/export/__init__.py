"""Export: material files for other programs — a glTF 2.0 asset of a sand patch and the texture
sets engines take — with the maps, bit depths and formats they need."""
