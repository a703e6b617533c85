// phongscene: POV-Ray 3.7 scene, classic mapping, from (built in Python)
// Render passes (animation frames): 1.
#version 3.7;
// (camera 0)
camera { perspective location <0.37, 2.13, 5.71> direction <-0.07480960086695655, -0.3506700040638589, -1.3839776160386963> right <1.3313896977033441, 2.3129646346357427e-18, -0.07196701068666726> up <-0.013239060060694972, 0.9694522380444902, -0.24492261112285693> }
global_settings { assumed_gamma 1.0 ambient_light rgb <0.17, 0.17, 0.17> }
background { color rgb <0.05, 0.07, 0.1> }
// (light 0)
light_source { <2.91, 4.63, 3.37> color rgb <3.0, 3.0, 3.0> }
// (material 0)
#declare Material_0 = texture { pigment { rgb <0.85, 0.18, 0.12> } finish { ambient 0.12 diffuse 0.23873241 phong 0.35 phong_size 24.0 } }
// (material 1)
#declare Material_1 = texture { pigment { rgb <0.2, 0.75, 0.25> } finish { ambient 0.12 diffuse 0.22281691 phong 0.3 phong_size 40.0 } }
// (material 2)
#declare Material_2 = texture { pigment { rgb <0.8, 0.6, 0.2> } finish { ambient 0.1 diffuse 0.19098593 phong 0.5 phong_size 18.0 } }
// (material 3)
#declare Material_3 = texture { pigment { rgb <0.62, 0.6, 0.55> } finish { ambient 0.15 diffuse 0.22281691 } }
// (sphere 0)
sphere { <0, 0, 0>, 1 matrix <0.3828964931956785, 0.07834316698964328, -0.2610605747417341, -0.05438923593256725, 0.888919098087252, 0.18698836346259093, 0.363404078734024, -0.08454741915108788, 0.5076309776544035, -1.41, 0.93, 0.12> texture { Material_0 } }
// (sphere 1)
sphere { <0, 0, 0>, 1 matrix <1.0668962131709905, 0.36640919674407335, -0.06615716788650527, -0.10083724295403089, 0.24138910379258782, -0.28924583143693017, -0.1450170783705163, 0.5079172587685117, 0.47443661876583715, 0.631, 0.713, -0.37> texture { Material_1 } }
// (sphere 2)
sphere { <0, 0, 0>, 1 matrix <0.09441476479257546, 0.2688756006844534, -0.05377512013689066, -0.7695405123037803, 0.291751507884077, 0.10764969842318459, 0.06860963603672257, 0.04798841977901, 0.360402316044198, 1.73, 1.21, 0.83> texture { Material_2 } }
// (mesh 0)
mesh2 {
  vertex_vectors { 4,
<-4.12999992e1,0,-6.37000008e1>,
<3.89000015e1,0,-6.10999985e1>,
<4.37000008e1,0,3.72999992e1>,
<-3.90999985e1,0,4.19000015e1>
  }
  face_indices { 2,
<0,2,1>,<0,3,2>
  }
  texture { Material_3 }
}
