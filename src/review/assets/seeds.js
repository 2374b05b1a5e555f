// mocap2d seeding page (serve CLIP --seeds-out): placing the first seeds; see docs/guide.md, "serve".
