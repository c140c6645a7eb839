// geometry: being written
