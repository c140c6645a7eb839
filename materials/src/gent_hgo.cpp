// gent_hgo: being written
