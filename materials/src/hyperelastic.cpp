// hyperelastic: being written
